"""The embedded demonstration behind ``belief demo``.

Two short stories, on data that ships with the package:

1. *Who did it?* (Shafer's model): a witness who is right 80 % of the time says the
   culprit is a man.  The report is discounted by its reliability, then fused with the
   later, certain evidence that Peter has an alibi (Dempster conditioning).
2. *Two doctors disagree* (Zadeh's example): two highly conflicting diagnoses fused by
   every rule of the registry, showing how each rule handles the conflict.
3. *Overlapping hypotheses* (DSmT): two categories that can hold at once, evidence on
   their intersection, and the same evidence read under a stricter (hybrid) model once
   it is learnt that they exclude each other (dynamic fusion).
"""

from __future__ import annotations

from typing import TextIO

from belief.frame import Frame
from belief.lattice import hyper_power_set
from belief.mass import MassFunction
from belief.model import Model
from belief.rules import combine

__all__ = ["run_demo"]


def _rows(out: TextIO, title: str, m: MassFunction, queries: list[str]) -> None:
    out.write(f"\n{title}\n")
    out.write("  mass: " + ", ".join(f"m({e.format('unicode')}) = {v:.4f}" for e, v in m.items()) + "\n")
    out.write(f"  {'proposition':<14}{'Bel':>8}{'Pls':>8}{'BetP':>8}\n")
    for q in queries:
        name = m.frame.element(q).format("unicode")   # written as in the mass line above, not as typed
        out.write(f"  {name:<14}{m.bel(q):>8.4f}{m.pls(q):>8.4f}{m.betp(q):>8.4f}\n")


def run_demo(out: TextIO) -> None:
    """Write the demonstration to ``out``.

    >>> import io
    >>> buffer = io.StringIO()
    >>> run_demo(buffer)
    >>> "Paul" in buffer.getvalue()
    True
    """
    suspects = Model.shafer(Frame(["Peter", "Paul", "Mary"]))
    out.write("belief demo: fusing uncertain evidence with belief functions\n")
    out.write("=" * 62 + "\n")
    out.write("1. Who did it?  Frame {Peter, Paul, Mary}, Shafer's model.\n")
    report = MassFunction.categorical("Peter|Paul", model=suspects)
    witness = report.discount(0.8)
    _rows(out, "A witness, right 80% of the time, says: a man (discounted, α = 0.8)",
          witness, ["Peter", "Paul", "Mary", "Peter|Paul"])
    fused = witness.condition("Paul|Mary")
    _rows(out, "Fused with the certain news that Peter has an alibi (conditioning on Paul ∪ Mary)",
          fused, ["Peter", "Paul", "Mary"])
    best = max(fused.pignistic().items(), key=lambda kv: kv[1])
    out.write(f"  decision by pignistic probability: {best[0]} ({best[1]:.2f})\n")

    out.write("\n2. Two doctors disagree (Zadeh's example).  Frame {meningitis, concussion, tumour}.\n")
    illnesses = Model.shafer(Frame(["meningitis", "concussion", "tumour"]))
    first = MassFunction({"meningitis": 0.9, "tumour": 0.1}, model=illnesses)
    second = MassFunction({"concussion": 0.9, "tumour": 0.1}, model=illnesses)
    out.write("  doctor 1: m(meningitis) = 0.9, m(tumour) = 0.1\n")
    out.write("  doctor 2: m(concussion) = 0.9, m(tumour) = 0.1\n")
    for rule in ("conjunctive", "dempster", "yager", "dubois_prade", "pcr6", "r_rule"):
        fused = combine(first, second, rule=rule)
        masses = ", ".join(f"{e.format('unicode')}: {v:.3f}" for e, v in fused.items())
        out.write(f"  {rule:<13}{masses}\n")
    out.write("  Dempster's rule is certain of the tumour both doctors found unlikely; the others show the conflict or move it to doubt.\n")

    out.write("\n3. Overlapping hypotheses.  Frame {a, b}: a target may be both at once (DSmT).\n")
    frame = Frame(["a", "b"])
    sizes = ", ".join(f"n={n}: {len(hyper_power_set(n))}" for n in range(1, 6))
    out.write(f"  |D^Θ| on the free model (∅ included): {sizes}\n")
    free = MassFunction({"a": 0.4, "b": 0.2, "a&b": 0.3, "a|b": 0.1}, frame=frame, model="free")
    _rows(out, "Evidence under the free DSm model", free, ["a", "b", "a&b"])
    exclusive = Model.hybrid(frame, empty=["a&b"])
    later = free.under(exclusive)
    out.write(f"\nLearnt later: a and b exclude each other; m(∅) = {later.empty_mass:.2f} was on a∩b\n")
    _rows(out, "The same evidence under the hybrid model (normalised)", later.normalized(), ["a", "b"])
    out.write("\nNext: belief lattice 3, belief measures BBA.json, belief combine --rule pcr6 A.json B.json\n")
