"""HOTA in ``belief eval``: equal to TrackEval's figures, and the laws of the metric.

The reference figures are TrackEval 1.3.0's (``MotChallenge2DBox``, preprocessing on, every
ground-truth row a pedestrian), stored in fixtures/hota/hota_fixtures.json by
fixtures/hota/make_hota_fixtures.py, which says how it was run; TrackEval itself is not
needed here.  PETS09-S2L1 is scored when its folder is next to the repository
(``shared/data/pets09_s2l1_f0001_0200``) and skipped otherwise.
"""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest

from belief.cli import main
from belief_tracking.errors import TrackingError
from belief_tracking.evaluation import Scores, evaluate
from belief_tracking.hota import ALPHAS, HOTA_FIELDS, hota
from belief_tracking.motfiles import read_mot

FIXTURES = Path(__file__).resolve().parent / "fixtures" / "hota"
REFERENCE = json.loads((FIXTURES / "hota_fixtures.json").read_text(encoding="ascii"))
#: Equality to TrackEval: the figures agree to about 1e-15; the promise is 1e-6.
TOLERANCE = 1e-6


def _cases():
    spec = importlib.util.spec_from_file_location("hota_cases", FIXTURES / "hota_cases.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


hota_cases = _cases()
SYNTHETIC = [name for name in REFERENCE["sequences"] if name != "pets09"]


def rows_of(name: str) -> tuple[np.ndarray, np.ndarray]:
    """The ground truth and tracks of a fixture sequence, read as ``belief eval`` reads them."""
    if name == "pets09":
        if not (hota_cases.PETS_FOLDER / "gt.txt").is_file():
            pytest.skip(f"PETS09-S2L1 is not in {hota_cases.PETS_FOLDER}")
        gt = read_mot(hota_cases.PETS_FOLDER / "gt.txt", what="ground-truth file")
        tracks = hota_cases.link_detections(hota_cases.read_rows(hota_cases.PETS_FOLDER / "det.txt"))
        return gt, tracks
    entry = REFERENCE["sequences"][name]
    return (read_mot(FIXTURES / entry["gt"], what="ground-truth file"),
            read_mot(FIXTURES / entry["tracks"], allow_empty=True))


def per_alpha(gt: np.ndarray, tracks: np.ndarray):
    scored = gt[gt[:, 6] != 0]
    return hota(scored[:, 0], scored[:, 1], scored[:, 2:6], tracks[:, 0], tracks[:, 1], tracks[:, 2:6])


def test_the_fixtures_cover_switches_flag0_and_a_clean_run():
    assert {"clean", "switches", "flag0", "crowded", "empty"} <= set(SYNTHETIC)
    assert "MotChallenge2DBox" in REFERENCE["reference"] and "make_hota_fixtures.py" in REFERENCE["made_by"]
    gt, tracks = rows_of("flag0")
    assert (gt[:, 6] == 0).any()
    gt, tracks = rows_of("switches")
    assert evaluate(gt, tracks).id_switches > 0
    assert evaluate(*rows_of("clean")).id_switches == 0


def check_against_trackeval(name: str) -> None:
    gt, tracks = rows_of(name)
    reference = REFERENCE["sequences"][name]
    scores = evaluate(gt, tracks).to_dict()
    for key in HOTA_FIELDS:
        assert abs(scores[key] - reference[key]) <= TOLERANCE, (key, scores[key], reference[key])
    detail = per_alpha(gt, tracks)
    for key in HOTA_FIELDS:
        np.testing.assert_allclose(getattr(detail, key), reference["per_alpha"][key], rtol=0, atol=TOLERANCE)
    for key in ("tp", "fn", "fp"):
        assert getattr(detail, key).tolist() == reference["per_alpha"][f"hota_{key}"]


@pytest.mark.parametrize("name", SYNTHETIC)
def test_hota_equals_trackeval(name):
    check_against_trackeval(name)


@pytest.mark.data
def test_hota_equals_trackeval_on_pets09():
    if "pets09" not in REFERENCE["sequences"]:
        pytest.skip("the fixtures were made without PETS09-S2L1")
    check_against_trackeval("pets09")


# -- laws ------------------------------------------------------------------------------------------
def walkers(ids=(1, 2, 3), frames=range(1, 21)) -> np.ndarray:
    return np.array([[f, i, 40.0 * i + 1.5 * f, 30.0 + 0.5 * f, 20.0, 50.0, 1] for f in frames for i in ids])


def test_perfect_tracks_score_one_everywhere():
    gt = walkers()
    tracks = gt.copy()
    tracks[:, 1] += 100                     # other ids: HOTA does not care how tracks are numbered
    scores = evaluate(gt, tracks)
    assert all(getattr(scores, key) == 1.0 for key in HOTA_FIELDS)


def test_no_tracks_score_zero_and_loca_one_as_trackeval():
    scores = evaluate(walkers(), np.zeros((0, 7)))
    assert all(getattr(scores, key) == 0.0 for key in HOTA_FIELDS if key != "loca")
    # TrackEval's LocA is max(1e-10, 0) / max(1e-10, 0) = 1 without any true positive.
    assert scores.loca == 1.0
    assert REFERENCE["sequences"]["empty"]["loca"] == 1.0


def test_a_swapped_id_lowers_assa_but_not_deta():
    gt = walkers(ids=(1, 2))
    tracks = gt.copy()
    late = tracks[:, 0] > 10
    tracks[late, 1] = np.where(tracks[late, 1] == 1, 2, 1)      # tracks 1 and 2 trade people from frame 11 on
    same, swapped = evaluate(gt, gt), evaluate(gt, tracks)
    assert swapped.deta == same.deta == 1.0 and swapped.detre == swapped.detpr == swapped.loca == 1.0
    assert swapped.assa == pytest.approx(1 / 3) and same.assa == 1.0     # each pair: 10 TPA, 10 FNA, 10 FPA
    assert swapped.hota == pytest.approx(np.sqrt(1 / 3))


@pytest.mark.parametrize("name", SYNTHETIC)
def test_hota_squared_is_deta_times_assa_at_every_alpha(name):
    detail = per_alpha(*rows_of(name))
    assert detail.hota.shape == ALPHAS.shape == (19,)
    np.testing.assert_allclose(detail.hota ** 2, detail.deta * detail.assa, rtol=1e-12, atol=1e-15)


def test_a_looser_box_counts_at_the_lower_thresholds_only():
    gt = walkers(ids=(1,), frames=range(1, 11))
    tracks = gt.copy()
    tracks[:, 2] += 10.0                    # 20 px wide boxes moved by 10 px: IoU (20-10)/(20+10) = 1/3
    detail = per_alpha(gt, tracks)
    assert detail.tp.tolist() == [10 if a <= 1 / 3 else 0 for a in ALPHAS]
    assert evaluate(gt, tracks).deta == pytest.approx(6 / 19)    # true positives at α = 0.05 .. 0.30


def test_tracks_on_flag0_boxes_are_false_positives_of_hota_only():
    gt = walkers(ids=(1, 2))
    gt[gt[:, 1] == 2, 6] = 0                 # person 2 is not scored
    scores = evaluate(gt, gt.copy())
    assert scores.ignored_predictions == 20 and scores.mota == 1.0      # CLEAR drops the tracks on person 2
    assert scores.detpr == 0.5 and scores.detre == 1.0                   # TrackEval keeps them


# -- the command line --------------------------------------------------------------------------------
def test_belief_eval_json_and_table_carry_hota(capsys):
    tracks, gt = FIXTURES / "switches_tracks.txt", FIXTURES / "switches_gt.txt"
    assert main(["eval", str(tracks), str(gt), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    reference = REFERENCE["sequences"]["switches"]
    for key in HOTA_FIELDS:
        assert data[key] == pytest.approx(reference[key], abs=TOLERANCE)
    assert list(data) == [f.name for f in Scores.__dataclass_fields__.values()]
    assert main(["eval", str(tracks), str(gt)]) == 0
    table = capsys.readouterr().out
    assert f"HOTA (higher-order tracking accuracy)  {reference['hota']:.4f}" in table
    for words in ("DetA (detection accuracy)", "AssA (association accuracy)", "LocA (localisation accuracy)",
                  "DetRe (detection recall)", "DetPr (detection precision)", "AssRe (association recall)",
                  "AssPr (association precision)"):
        assert words in table


def test_hota_takes_empty_sides_and_refuses_ragged_arrays():
    gt = walkers(ids=(1,), frames=range(1, 4))
    none = np.zeros((0, 7))
    only_tracks = hota(none[:, 0], none[:, 1], none[:, 2:6], gt[:, 0], gt[:, 1], gt[:, 2:6])
    assert only_tracks.fp.tolist() == [3] * 19 and only_tracks.means()["detpr"] == 0.0
    nothing = hota(none[:, 0], none[:, 1], none[:, 2:6], none[:, 0], none[:, 1], none[:, 2:6]).means()
    assert nothing["hota"] == 0.0 and nothing["loca"] == 1.0
    with pytest.raises(TrackingError, match="one of each per row"):
        hota(gt[:, 0], gt[:1, 1], gt[:, 2:6], gt[:, 0], gt[:, 1], gt[:, 2:6])
