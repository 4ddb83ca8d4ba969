"""The documentation site builds with ``mkdocs build --strict``, API reference included."""

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def test_the_site_builds_strictly_with_the_api_reference(tmp_path):
    site = tmp_path / "site"
    result = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(site)],
                            cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, f"mkdocs build --strict failed:\n{result.stderr}"
    assert (site / "index.html").is_file()
    for page in ("theory", "rules", "tutorials/fusion", "tutorials/tracking", "results"):
        assert (site / page / "index.html").is_file(), f"the site has no page {page}/"

    reference = (site / "reference" / "belief" / "index.html").read_text(encoding="utf-8")
    # The first line of the MassFunction docstring, rendered from the source.
    assert "A mass function m: D^Θ → [0, 1] with Σ m = 1 (W (1))." in reference
    assert 'id="belief.mass.MassFunction"' in reference
    assert 'id="belief.rules.combine"' in reference
    plugin = (site / "reference" / "video_tracking" / "index.html").read_text(encoding="utf-8")
    assert 'id="belief_tracking.config.TrackerConfig"' in plugin
    # Sphinx roles in docstrings are turned into code or links, never shown raw.
    assert ":class:`" not in reference and ":class:`" not in plugin
