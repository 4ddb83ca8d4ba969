"""The ``belief`` command line.

Subcommands: ``lattice``, ``measures``, ``transform``, ``combine``, ``rules``, ``decide``, ``distance``,
``uncertainty``, ``plot`` and ``demo``.  Plugins add their own
through the entry-point group ``belief.commands``: each entry point is a callable
``register(subparsers)`` that adds parsers to the sub-parser collection, and sets a
``func(args) -> int`` default on each.  The core never imports a plugin by name.

Every command, a plugin's included, takes ``-q`` (only results and errors: no note,
announcement or progress bar) and ``-v`` (details on standard error: the inputs, model,
rule, representation and limits in effect, and the time taken), before or after its name;
a plugin reads them as ``args.quiet`` and ``args.verbose`` (:func:`verbosity`).  Every
command that prints results has ``--json``.

Bad input (an unknown hypothesis, masses that do not sum to one, a malformed file …)
ends with one line on standard error naming the problem and exit status 1; a wrong
command line ends with one line and status 2.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import sys
import time
from collections.abc import Sequence
from importlib.metadata import entry_points
from typing import Any

from belief.errors import BeliefError, FormatError, ResourceLimitError
from belief.frame import Frame
from belief.lattice import check_lattice_size, hyper_power_set
from belief.mass import MassFunction, check_cardinality_range
from belief.model import Model
from belief.textfiles import load_json, read_text

__all__ = ["main", "build_parser", "verbosity", "ENTRY_POINT_GROUP", "MODEL_NAMES", "CONJUNCTIVE_WITHOUT_CONFLICT"]

ENTRY_POINT_GROUP = "belief.commands"


class CommandError(Exception):
    """A problem with the command line itself (exit status 2)."""


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # one line, no usage block
        raise CommandError(f"{self.prog}: error: {message} (see '{self.prog} --help')")


# -- helpers ------------------------------------------------------------------------------------
#: The name that stands for standard input where a command reads a file (``belief combine ... --json | belief
#: transform - --pignistic``).
STDIN = "-"
_stdin = {"read": False}


def _read_json(path: str, what: str) -> Any:
    if path == STDIN:
        return load_json(_stdin_text(what), f"{what} on standard input")
    return load_json(read_text(path, what), f"{what} {path!r}")


def _stdin_text(what: str) -> str:
    """Standard input as UTF-8 text, read once per command and no more than ``MAX_TEXT_BYTES``."""
    from belief import textfiles

    if _stdin["read"]:
        raise CommandError(f"belief: error: standard input ('-') can be read only once, and the {what} asks for it "
                           "again; save one of them to a file")
    _stdin["read"] = True
    limit = textfiles.MAX_TEXT_BYTES
    data = sys.stdin.buffer.read(limit + 1)
    if len(data) > limit:
        raise FormatError(f"cannot read the {what} on standard input: more than belief.textfiles.MAX_TEXT_BYTES = "
                          f"{limit:,} bytes")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        raise FormatError(f"cannot read the {what} on standard input: not UTF-8 text") from None


def _read_bba(path: str) -> MassFunction:
    data = _read_json(path, "BBA file")
    try:
        m = MassFunction.from_dict(data)
    except BeliefError as exc:
        raise type(exc)(f"{'standard input' if path == STDIN else path}: {exc}") from None
    if _voice["level"] > 0:
        _detail(_describe_source(path, m))
    return m


#: The names that ``--model`` takes besides a model file: the model of that type over the sources' frame.
MODEL_NAMES = ("free", "shafer")


def _model_data(text: str) -> Any:
    """The JSON data of ``--model``: ``free`` or ``shafer`` name a model (a file of that name is ``./shafer``), any
    other text is a model file."""
    if text in MODEL_NAMES:
        return {"type": text}
    return _read_json(text, "model file")


def _model_from(path: str, frame: Frame, data: Any) -> Model:
    """The model of a model file's JSON ``data``; an error names the file."""
    try:
        return Model.from_dict(frame, data)
    except BeliefError as exc:
        raise type(exc)(f"{path}: {exc}") from None


def _print_json(data: Any) -> None:
    print(json.dumps(data, indent=2, ensure_ascii=False))


# -- what a command says besides its results (-q / -v) ------------------------------------------
#: The verbosity of the running command, set by :func:`main` from -q and -v: -1 quiet, 0 normal, 1 and more verbose;
#: and the command's name, which starts each of its lines on standard error.
_voice = {"level": 0, "command": ""}


def verbosity(args: argparse.Namespace) -> int:
    """-1 when ``args`` has -q, else the number of -v (0 without either).

    Plugins read ``args.quiet`` and ``args.verbose`` the same way; a parser made without the ``belief``
    command line (and so without these options) counts as neither.
    """
    if getattr(args, "quiet", False):
        return -1
    return int(getattr(args, "verbose", 0) or 0)


def _note(text: str) -> None:
    """A note on standard error (not a result, not an error): one line, left out with -q."""
    if _voice["level"] >= 0:
        print(f"belief {_voice['command']}: {_one_line(text)}", file=sys.stderr, flush=True)


def _detail(text: str) -> None:
    """A detail on standard error, printed only with -v."""
    if _voice["level"] > 0:
        print(f"belief {_voice['command']}: {_one_line(text)}", file=sys.stderr, flush=True)


def _describe_model(model: Model) -> str:
    """The model in a few words, for -v and the notes."""
    if model.kind == "shafer":
        return "Shafer's model (exclusive hypotheses)"
    if model.kind == "tracking":
        return f"the tracking model (false alarm {model.false_alarm})"
    if not model.constrained:
        return "the free DSm model (no empty intersection)"
    terms = model.forbidden
    shown = ", ".join(model.frame.term_name(t) for t in terms[:6]) + (", ..." if len(terms) > 6 else "")
    return f"a hybrid model with {len(terms)} empty conjunction{'s' if len(terms) != 1 else ''} ({shown})"


def _describe_source(path: str, m: MassFunction) -> str:
    where = "standard input" if path == STDIN else path
    names = ", ".join(m.frame.hypotheses[:8]) + (", ..." if len(m.frame) > 8 else "")
    return (f"{where}: {len(m)} focal element{'s' if len(m) != 1 else ''} on a frame of "
            f"{len(m.frame)} hypotheses ({names}) under {_describe_model(m.model)}")


def _limits_in_effect(flags: dict) -> str:
    """The limits of ``flags`` (option -> full name of the limit) as they stand, for -v."""
    import importlib

    shown = []
    for name in flags.values():
        module_name, attribute = name.rsplit(".", 1)
        shown.append(f"{attribute} = {getattr(importlib.import_module(module_name), attribute):,}")
    return "limits in effect: " + ", ".join(shown)


def _print_mass(m: MassFunction, as_json: bool) -> None:
    """A resulting mass function: a BBA file with ``--json``, else a table."""
    if as_json:
        _print_json(m.to_dict())
    else:
        print(_table(["proposition", "mass"], list(m.to_mapping().items())))


def _table(header: Sequence[str], rows: Sequence[Sequence[Any]]) -> str:
    """Rows under a header and a rule, the first column left-aligned and the others right-aligned."""
    # Column by column: a result of thousands of focal elements prints in a millisecond.
    columns = [[str(h)] + _cells(column) for h, column in zip(header, zip(*rows))] if rows else \
        [[str(h)] for h in header]
    widths = [max(map(len, column)) for column in columns]
    if len(columns) == 2:                   # a right-aligned last column leaves nothing to strip
        left, right = widths
        lines = list(map(f"{{:<{left}}}  {{:>{right}}}".format, *columns))
    else:
        padded = [[c.ljust(widths[0]) for c in columns[0]]] + [[c.rjust(w) for c in column]
                                                               for column, w in zip(columns[1:], widths[1:])]
        lines = ["  ".join(parts).rstrip() for parts in zip(*padded)]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def _cells(column: Sequence[Any]) -> list[str]:
    # One builtin over the whole column where its cells are all of one kind.
    kinds = set(map(type, column))
    if kinds == {float}:
        return list(map(_SIX_DECIMALS, column))
    if kinds == {str}:
        return list(column)
    return [_fmt(c) for c in column]


_SIX_DECIMALS = "{:.6f}".format


def _fmt(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:.6f}"
    return str(value)


# -- lattice --------------------------------------------------------------------------------------
def _cmd_lattice(args: argparse.Namespace) -> int:
    if args.frame is not None and args.n is not None:
        raise CommandError("belief lattice: error: give either N or --frame, not both")
    data = _model_data(args.model) if args.model else None
    if args.frame is not None:
        frame = Frame.parse(args.frame)
    elif args.n is not None:
        if args.n < 1:
            raise CommandError(f"belief lattice: error: N must be a positive number of hypotheses, got {args.n}")
        # Refused before the frame of N names is made: N can be far beyond memory.
        check_lattice_size(args.n, data)
        frame = Frame.numbered(args.n)
    else:
        raise CommandError("belief lattice: error: give the number of hypotheses N or --frame a,b,c")
    model = _model_from(args.model, frame, data) if args.model else Model.free(frame)
    _detail(f"{len(frame)} hypotheses under {_describe_model(model)}")
    lattice = hyper_power_set(model)
    if args.json:
        _print_lattice_json(lattice, with_elements=not args.count)
    elif args.count:
        print(len(lattice))
    else:
        out = sys.stdout
        for block in lattice.text_blocks("\n"):
            out.write(block + "\n")
    return 0


def _print_lattice_json(lattice, with_elements: bool) -> None:
    """The lattice as ``json.dumps(..., indent=2)`` would print it, written as the elements are made.

    Millions of elements would otherwise be held three times over: as strings, in a list,
    and in one JSON text.
    """
    head = json.dumps({"frame": list(lattice.frame.hypotheses), "count": len(lattice)}, indent=2, ensure_ascii=False)
    out = sys.stdout
    if not with_elements:
        out.write(head + "\n")
        return
    out.write(head[:-2] + ',\n  "elements": [')
    first = True
    for block in lattice.text_blocks('",\n    "', json_escaped=True):
        out.write(("\n" if first else ",\n") + '    "' + block + '"')
        first = False
    out.write("\n  ]\n}\n")


# -- measures ---------------------------------------------------------------------------------------
def _queries(m: MassFunction, given: Sequence[str] | None) -> list[str]:
    if given:
        for q in given:
            m.frame.element(q)  # fail early, with the query named
        return list(given)
    return [str(e) for e in m.focal]


#: How many pairs of hypotheses the overlap note looks at (it names the first few it finds).
_OVERLAP_PAIRS_CHECKED = 2_000


def _overlap_note(m: MassFunction, queries: Sequence[str], what: str) -> None:
    """Say why the probabilities of the queried hypotheses may sum to more than one: they overlap."""
    model, frame = m.model, m.frame
    names = [q for q in queries if q in frame]
    if model.kind == "shafer" or len(names) < 2:
        return
    shared = []
    for k, (a, b) in enumerate((a, b) for i, a in enumerate(names) for b in names[i + 1:]):
        if k >= _OVERLAP_PAIRS_CHECKED or len(shared) > 3:
            break
        if not model.is_empty(frame.element(f"{a}&{b}")):
            shared.append(f"{a}∩{b}")
    if shared:
        listed = ", ".join(shared[:3]) + (", ..." if len(shared) > 3 else "")
        _note(f"{what} of the hypotheses need not sum to 1: under the {model.kind} model they overlap ({listed} "
              "not empty), and a region they share counts for each of them")


def _empty_queries_note(m: MassFunction, queries: Sequence[str]) -> list[str]:
    """The queries as the table shows them, an empty one marked "= ∅", with a note naming those."""
    empty = [q for q in queries if m.model.is_empty(m.frame.element(q))]
    if not empty:
        return list(queries)
    _note(f"{', '.join(empty[:3])}{', ...' if len(empty) > 3 else ''} {'is' if len(empty) == 1 else 'are'} empty "
          f"under the {m.model.kind} model: Bel, Pls and BetP of ∅ are 0 and its commonality q(∅) is 1")
    marked = set(empty)
    return [f"{q} (= ∅)" if q in marked else q for q in queries]


def _cmd_measures(args: argparse.Namespace) -> int:
    m = _read_bba(args.bba)
    queries = _queries(m, args.query)
    check_cardinality_range(m, "BetP")
    batch = m.batch()
    columns = {name: getattr(batch, name)(queries)[0].tolist() for name in ("bel", "pls", "q", "betp")}
    if args.json:
        _print_json({q: {name: columns[name][i] for name in columns} for i, q in enumerate(queries)})
    else:
        shown = _empty_queries_note(m, queries) if args.query else queries   # focal elements are never empty
        rows = [[q] + [columns[name][i] for name in columns] for i, q in enumerate(shown)]
        print(_table(["proposition", "bel", "pls", "q", "betp"], rows))
    _overlap_note(m, queries, "BetP")
    return 0


# -- transform ---------------------------------------------------------------------------------------
def _refuse_extras(args: argparse.Namespace, option: str) -> None:
    """--normalized and --query belong to other transforms than ``option``."""
    for flag in ("normalized", "query"):
        if getattr(args, flag):
            raise CommandError(f"belief transform: error: --{flag} does not go with {option}")


def _cmd_transform(args: argparse.Namespace) -> int:
    m = _read_bba(args.bba)
    if args.plausibility:
        from belief.representations import plausibility_transform

        _refuse_extras(args, "--plausibility")
        probability = dict(zip(m.frame.hypotheses, plausibility_transform(m).tolist()))
        if args.json:
            _print_json({"probability": probability})
        else:
            print(_table(["hypothesis", "plausibility transform"], list(probability.items())))
        return 0
    if args.contextual_discount is not None:
        from belief.representations import contextual_discount

        _refuse_extras(args, "--contextual-discount")
        rates = _read_json(args.contextual_discount, "discount-rates file")
        if not isinstance(rates, dict):
            raise FormatError(f"{args.contextual_discount}: the discount rates must be a JSON object mapping each "
                              f"hypothesis to its rate α, got {type(rates).__name__}")
        _print_mass(contextual_discount(m, rates), args.json)
        return 0
    if args.pignistic or args.dsmp is not None:
        if args.normalized:
            raise CommandError("belief transform: error: --normalized goes with --condition")
        names = list(m.frame.hypotheses)
        extra = [q for q in _queries(m, args.query) if q not in names] if args.query else []
        queries = names + extra
        if args.pignistic:
            check_cardinality_range(m, "BetP")
            values = m.batch().betp(queries)[0].tolist()
        else:
            check_cardinality_range(m, "DSmP", args.dsmp)
            values = m.batch().dsmp(queries, epsilon=args.dsmp)[0].tolist()
        probability = dict(zip(queries, values))
        if args.json:
            _print_json({"probability": probability})
        else:
            label = "BetP" if args.pignistic else f"DSmP(ε={args.dsmp:g})"
            print(_table(["proposition", label], list(probability.items())))
        _overlap_note(m, names, "BetP" if args.pignistic else "DSmP")
        return 0
    if args.query:
        raise CommandError("belief transform: error: --query goes with --pignistic or --dsmp")
    if args.discount is not None:
        if args.normalized:
            raise CommandError("belief transform: error: --normalized goes with --condition")
        result = m.discount(args.discount)
    else:
        result = m.condition(args.condition, normalized=args.normalized)
    _print_mass(result, args.json)
    return 0


# -- combine and rules ------------------------------------------------------------------------
def _cmd_combine(args: argparse.Namespace) -> int:
    from belief.rules import combine, get_rule

    info = get_rule(args.rule)
    if len(args.bba) < 2:
        raise CommandError("belief combine: error: give at least two BBA files")
    sources = [_read_bba(path) for path in args.bba]
    model = None
    if args.model:
        model = _model_from(args.model, sources[0].frame, _model_data(args.model))
    options = {}
    if args.r_mode is not None:
        options["r_mode"] = args.r_mode
    if args.empty_mode is not None:
        options["empty_mode"] = args.empty_mode
    for k, source in enumerate(sources[1:], start=2):
        if source.model != sources[0].model:
            raise FormatError(f"{args.bba[k - 1]} was elicited under another frame or model than {args.bba[0]}")
    fusion_model = model if model is not None else sources[0].model
    if _voice["level"] > 0:
        _combine_details(info, sources, fusion_model, options)
    with _option_limits(args, LIMIT_FLAGS):
        result = combine(*sources, rule=info, model=model, **options)
    if info.name in CONJUNCTIVE_WITHOUT_CONFLICT and _no_empty_intersection(fusion_model):
        _note(f"the model has no empty intersection (the free DSm model), so {info.name} has no conflict to "
              "redistribute and gives the conjunctive rule's result; for exclusive hypotheses give --model shafer, "
              'or "model": {"type": "shafer"} in the BBA files')
    if _voice["level"] > 0:             # len(m) counts without making the focal elements
        _detail(f"result: {len(result)} focal element{'s' if len(result) != 1 else ''}")
    _print_mass(result, args.json)
    return 0


#: The rules that send the mass of the products on empty intersections (the conflict) somewhere, or keep it on ∅:
#: under a model with no empty intersection there is none, and each gives the conjunctive rule's result, which
#: ``belief combine`` then says (tests/test_cli_quiet_json.py checks every one).  The R-weighted rule is not among
#: them (it weighs every product by R, conflicting or not), nor the disjunctive, averaging, cautious and bold rules.
CONJUNCTIVE_WITHOUT_CONFLICT = frozenset({"dsmc", "dempster", "yager", "dubois_prade", "dsmh", "pcr5", "pcr6",
                                          "pcr5_plus", "pcr6_plus"})


def _no_empty_intersection(model: Model) -> bool:
    """Whether no intersection of hypotheses is empty under ``model`` (the free DSm model, whatever its type says).

    A frame of one hypothesis has no intersection of two: no note is due there.
    """
    return len(model.frame) > 1 and not model.constrained


def _combine_details(info, sources: Sequence[MassFunction], model: Model, options: dict) -> None:
    """What ``belief combine -v`` says before combining: the rule, the fusion model, the work and the limits."""
    import math

    from belief.plan import coded_fast

    given = ", ".join(f"{k}={v}" for k, v in options.items())
    _detail(f"rule {info.name}{f' ({given})' if given else ''}: {info.summary}; "
            f"{'associative' if info.associative else 'not associative: the sources are combined jointly'}")
    dynamic = "" if model == sources[0].model else " (dynamic fusion: stricter than the sources' model)"
    _detail(f"fusion model: {_describe_model(model)}{dynamic}")
    tuples = math.prod(len(s.focal) for s in sources)
    fast = coded_fast(model, [list(s.focal) for s in sources])
    how = ("integer codes of the focal elements, combined by numpy" if fast else
           "elements combined one tuple at a time (no integer codes under this model)")
    _detail(f"{len(sources)} sources, {tuples:,} tuple{'s' if tuples != 1 else ''} of focal elements; "
            f"representation: {how}")
    _detail(_limits_in_effect(LIMIT_FLAGS))


#: The options of ``belief combine`` that raise (or lower) a limit of a combination, and the limit each sets.
LIMIT_FLAGS = {"max-tuples": "belief.plan.MAX_TUPLES", "max-work": "belief.plan.MAX_WORK",
               "max-bytes": "belief.plan.MAX_BYTES", "max-element-tuples": "belief.plan.MAX_ELEMENT_TUPLES",
               "max-plus-tuples": "belief.extra_rules.MAX_PLUS_TUPLES"}


#: The options of the commands that measure a mass function (``measures``, ``transform``, ``decide``, ``distance``,
#: ``uncertainty``) that raise a limit of the tables relating its focal elements to the queries.
TABLE_LIMIT_FLAGS = {"max-table-entries": "belief.batch.MAX_TABLE_ENTRIES",
                     "max-element-entries": "belief.batch.MAX_ELEMENT_ENTRIES"}


#: What a measuring command's user does instead of asking for "fewer queries", where that is not the advice.
_TABLE_ADVICE = {"measures": "ask for fewer queries (--query PROP ...)",
                 # discord, dissonance and confusion weigh BetP, Pls or Bel of every focal element
                 "uncertainty": "leave out discord, dissonance and confusion (--measure nonspecificity deng ambiguity)"}


def _run_measuring(args: argparse.Namespace) -> int:
    """Run a measuring command with the table limits its options set; a refusal names the option."""
    with _option_limits(args, TABLE_LIMIT_FLAGS, {"ask for fewer queries": _TABLE_ADVICE.get(args.command)}):
        if _voice["level"] > 0:
            _detail(_limits_in_effect(TABLE_LIMIT_FLAGS))
        return args.measuring(args)


@contextlib.contextmanager
def _option_limits(args: argparse.Namespace, flags: dict, advice: dict | None = None):
    """Set the limits that ``flags`` (option -> limit) gave values for the block; a refusal over one of them names
    its option, not a module attribute, with any ``advice`` (library text -> command-line text) rewritten."""
    given = {name: getattr(args, flag.replace("-", "_")) for flag, name in flags.items()}
    try:
        with _limits({name: value for name, value in given.items() if value is not None}):
            yield
    except ResourceLimitError as exc:
        flag = next((f for f, name in flags.items() if name == exc.limit), None)
        if flag is None:
            raise
        message = str(exc).replace(f"or raise {exc.limit}", f"or raise it with --{flag} N")
        for library, command_line in (advice or {}).items():
            if command_line:
                message = message.replace(library, command_line)
        raise type(exc)(message, exc.limit) from None


def _limit_value(text: str) -> int:
    """A limit given on the command line: a positive whole number, as ``4000000``, ``4_000_000`` or ``4e6``."""
    try:
        value = float(text.replace("_", "")) if any(c in text for c in ".eE") else int(text.replace("_", ""))
    except ValueError:
        value = None
    if value is None or not 0 < value < 2**63 or value != int(value):
        raise argparse.ArgumentTypeError(f"a limit must be a positive whole number below 2**63, got {text!r}")
    return int(value)


@contextlib.contextmanager
def _limits(values: dict):
    """Set limits of :mod:`belief.plan` and :mod:`belief.extra_rules` (full names) for the time of the block."""
    import importlib

    saved = []
    try:
        for name, value in values.items():
            module_name, attribute = name.rsplit(".", 1)
            module = importlib.import_module(module_name)
            saved.append((module, attribute, getattr(module, attribute)))
            setattr(module, attribute, value)
        yield
    finally:
        for module, attribute, value in reversed(saved):
            setattr(module, attribute, value)


def _cmd_rules(args: argparse.Namespace) -> int:
    from belief.rules import RULES

    if args.json:
        _print_json([{"name": info.name, "aliases": list(info.aliases), "summary": info.summary,
                      "associative": info.associative, "keeps_conflict": info.keeps_conflict,
                      "options": list(info.options)} for info in RULES.values()])
        return 0
    rows = []
    for info in RULES.values():
        names = info.name + (f" ({', '.join(info.aliases)})" if info.aliases else "")
        rows.append((names, info.summary))
    width = max(len(r[0]) for r in rows)
    for names, summary in rows:
        print(f"{names.ljust(width)}  {summary}")
    return 0


# -- decide, distance, uncertainty, plot -------------------------------------------------------------------
def _cmd_decide(args: argparse.Namespace) -> int:
    from belief.decisions import decide

    m = _read_bba(args.bba)
    options = {} if args.epsilon is None else {"epsilon": args.epsilon}
    if args.epsilon is not None and args.criterion != "dsmp":
        raise CommandError("belief decide: error: --epsilon goes with --criterion dsmp")
    if args.criterion in ("betp", "dsmp"):
        check_cardinality_range(m, args.criterion.replace("betp", "BetP").replace("dsmp", "DSmP"),
                                (0.001 if args.epsilon is None else args.epsilon) if args.criterion == "dsmp" else None)
    decision = decide(m, args.criterion, args.candidates or None, tol=args.tolerance, **options)
    if args.json:
        _print_json({"decision": list(decision.elements), "value": decision.value})
    else:
        tied = " (tied)" if len(decision.elements) > 1 else ""
        print(f"{', '.join(decision.elements)}{tied}: {args.criterion} = {_fmt(decision.value)}")
    return 0


def _cmd_distance(args: argparse.Namespace) -> int:
    from belief.distances import distance

    first, second = _read_bba(args.first), _read_bba(args.second)
    value = float(distance(first, second, kind=args.kind))
    if args.json:
        _print_json({"distance": value})
    else:
        print(f"{args.kind} distance: {_fmt(value)}")
    return 0


def _cmd_uncertainty(args: argparse.Namespace) -> int:
    from belief.uncertainty import uncertainty

    m = _read_bba(args.bba)
    values = {name: float(value) for name, value in uncertainty(m, args.measure or None).items()}
    if args.json:
        _print_json(values)
    else:
        print(_table(["measure", "bits"], list(values.items())))
    return 0


def _cmd_plot(args: argparse.Namespace) -> int:
    """``belief plot``: the picture is written to exactly ``--out`` (PNG when it has no suffix), then named."""
    from belief.plot import plot_mass

    target = _picture_path(args.out)
    m = _read_bba(args.bba)
    figure = plot_mass(m, title=args.title or args.bba)
    _save_picture(figure, target)
    if args.json:
        _print_json({"file": str(target), "format": target.suffix[1:].lower() or "png"})
    else:
        print(f"wrote {target}")
    return 0


def _picture_path(text: str):
    """``--out`` of ``belief plot`` as a Path, refused before any work if no file can be written there."""
    import os
    from pathlib import Path

    from belief.errors import OutputPathError

    if not text.strip():
        raise OutputPathError("--out must name the picture to write, got an empty path")
    path = Path(text)
    folder = path.parent
    try:
        if path.is_dir():
            raise OutputPathError(f"--out {text}: it is a folder; name the picture to write in it")
        if not folder.is_dir():
            raise OutputPathError(f"--out {text}: there is no folder {folder} to write it in")
        limit = os.pathconf(folder, "PC_NAME_MAX") if hasattr(os, "pathconf") else 255
    except OSError as exc:
        raise OutputPathError(f"--out {text}: {_path_reason(exc)}") from None
    if len(os.fsencode(path.name)) > limit:
        raise OutputPathError(f"--out {text}: the file name is {len(os.fsencode(path.name))} bytes long, over the "
                              f"file system's limit of {limit}")
    return path


def _save_picture(figure, path) -> None:
    """Write ``figure`` to a new file beside ``path``, then rename it to ``path`` (a symlink there is replaced).

    The format is the suffix's, PNG without one: matplotlib would otherwise add ``.png`` to a
    name without a suffix, and the file written would not be the one named.
    """
    import os
    import secrets

    from belief.errors import OutputPathError

    kind = path.suffix[1:].lower() or "png"
    known = figure.canvas.get_supported_filetypes()
    if kind not in known:
        raise FormatError(f"cannot write the picture {str(path)!r}: matplotlib writes {', '.join(sorted(known))}, "
                          f"not {kind}")
    staged = path.with_name(f".{path.name[:200]}.partial-{secrets.token_hex(4)}")
    try:
        # O_EXCL: never through an existing name, a symlink included.
        handle = os.open(staged, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0), 0o666)
        try:
            with os.fdopen(handle, "wb") as stream:
                figure.savefig(stream, format=kind)
            os.replace(staged, path)
        except BaseException:
            staged.unlink(missing_ok=True)
            raise
    except OSError as exc:
        raise OutputPathError(f"cannot write the picture {str(path)!r}: {_path_reason(exc)}") from None


def _path_reason(exc: OSError) -> str:
    import errno

    if exc.errno == errno.ENAMETOOLONG:
        return "a name in the path is over the file system's length limit"
    return exc.strerror or str(exc)


# -- demo ----------------------------------------------------------------------------------------------
def _cmd_demo(args: argparse.Namespace) -> int:
    from belief.demo import run_demo

    run_demo(sys.stdout)
    return 0


# -- parser ---------------------------------------------------------------------------------------------
def _table_limit_options(parser: argparse.ArgumentParser) -> None:
    for flag, name in TABLE_LIMIT_FLAGS.items():
        parser.add_argument(f"--{flag}", type=_limit_value, metavar="N",
                            help=f"raise (or lower) {name} (see the docs' Limits and errors page)")


def build_parser() -> argparse.ArgumentParser:
    """The argument parser, with the plugins' subcommands registered."""
    parser = _Parser(prog="belief", description="Evidence fusion with belief functions (DST and DSmT).",
                     epilog="Wherever a command reads a BBA, model or rates file, '-' reads it from standard input "
                            "(once a command), so that --json output feeds the next command.")
    from belief import __version__

    parser.add_argument("--version", action="version", version=f"belief {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)

    p = sub.add_parser("lattice", help="list or count the hyper-power set D^Θ",
                       description="List or count D^Θ (∅ included) under a model.")
    p.add_argument("n", nargs="?", type=int, metavar="N", help="number of hypotheses, named t1..tN")
    p.add_argument("--frame", metavar="a,b,c", help="comma-separated hypothesis names")
    p.add_argument("--model", metavar="MODEL.json", help="model file (default: free DSm model)")
    p.add_argument("--count", action="store_true", help="print only the number of elements")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=_cmd_lattice)

    p = sub.add_parser("measures", help="bel, pls, q and betp of propositions",
                       description="Belief, plausibility, commonality and pignistic probability.")
    p.add_argument("bba", metavar="BBA.json")
    p.add_argument("--query", nargs="+", action="extend", metavar="PROP",
                   help="propositions (default: every focal element); --query A B and --query A --query B alike")
    p.add_argument("--json", action="store_true", help="print JSON")
    _table_limit_options(p)
    p.set_defaults(func=_run_measuring, measuring=_cmd_measures)

    p = sub.add_parser("transform", help="pignistic/DSmP/plausibility probabilities, discounting, conditioning",
                       description="Probabilistic transformations and operations on one mass function.")
    p.add_argument("bba", metavar="BBA.json")
    how = p.add_mutually_exclusive_group(required=True)
    how.add_argument("--pignistic", action="store_true", help="generalised pignistic transformation BetP")
    how.add_argument("--dsmp", type=float, metavar="EPS", help="DSmP with the given ε")
    how.add_argument("--discount", type=float, metavar="ALPHA", help="Shafer discounting, α = reliability")
    how.add_argument("--condition", metavar="PROP", help="Dempster conditioning on PROP")
    how.add_argument("--plausibility", action="store_true",
                     help="plausibility transform: P(θ) ∝ Pls(θ) (Cobb and Shenoy)")
    how.add_argument("--contextual-discount", metavar="RATES.json",
                     help="contextual discounting: RATES.json maps each hypothesis θ to its rate α_θ")
    p.add_argument("--normalized", action="store_true", help="with --condition: remove m(∅) and rescale")
    p.add_argument("--query", nargs="+", action="extend", metavar="PROP",
                   help="extra propositions for --pignistic/--dsmp")
    p.add_argument("--json", action="store_true", help="print JSON")
    _table_limit_options(p)
    p.set_defaults(func=_run_measuring, measuring=_cmd_transform)

    p = sub.add_parser("combine", help="combine BBA files with a rule",
                       description="Combine two or more mass functions with a combination rule.")
    p.add_argument("bba", nargs="+", metavar="BBA.json", help="the sources (at least two), all under one model")
    p.add_argument("--rule", default="dempster", metavar="RULE",
                   help="a rule name (see 'belief rules'); Dempster's rule by default, as combine() in Python")
    p.add_argument("--model", metavar="MODEL.json", help="fusion model (default: the sources' model)")
    p.add_argument("--r-mode", choices=["paper", "euclid", "jousselme"], help="r_rule: how R is measured")
    p.add_argument("--empty-mode", choices=["union", "empty"], help="r_rule: where R·k goes when A∩B is empty")
    p.add_argument("--json", action="store_true", help="print the result as a BBA file")
    for flag, name in LIMIT_FLAGS.items():
        p.add_argument(f"--{flag}", type=_limit_value, metavar="N",
                       help=f"raise (or lower) {name} for this combination (see the docs' Limits and errors page)")
    p.set_defaults(func=_cmd_combine)

    p = sub.add_parser("rules", help="list the combination rules", description="List the combination rules.")
    p.add_argument("--json", action="store_true",
                   help="print a JSON list: name, aliases, summary, associative, keeps_conflict, options")
    p.set_defaults(func=_cmd_rules)

    p = sub.add_parser("decide", help="the hypothesis (or candidate) of largest Bel, Pls, BetP or DSmP",
                       description="Decide: the singleton (or given candidate) maximising a criterion; ties are "
                                   "all listed.")
    p.add_argument("bba", metavar="BBA.json")
    p.add_argument("--criterion", choices=["betp", "bel", "pls", "dsmp"], default="betp",
                   help="what to maximise (default betp)")
    p.add_argument("--candidates", nargs="+", action="extend", metavar="PROP",
                   help="propositions to choose among (default: the hypotheses)")
    p.add_argument("--epsilon", type=float, metavar="EPS", help="ε of DSmP (default 0.001)")
    p.add_argument("--tolerance", type=float, default=1e-9, metavar="TOL",
                   help="values within TOL of the largest are tied (default 1e-9)")
    p.add_argument("--json", action="store_true", help='print {"decision": [...], "value": x}')
    _table_limit_options(p)
    p.set_defaults(func=_run_measuring, measuring=_cmd_decide)

    from belief.distances import DISTANCES

    p = sub.add_parser("distance", help="the distance between two mass functions",
                       description="The distance between two mass functions under the same model.")
    p.add_argument("first", metavar="A.json")
    p.add_argument("second", metavar="B.json")
    p.add_argument("--kind", choices=list(DISTANCES), default="jousselme",
                   help="which distance (default jousselme)")
    p.add_argument("--json", action="store_true", help='print {"distance": x}')
    _table_limit_options(p)
    p.set_defaults(func=_run_measuring, measuring=_cmd_distance)

    p = sub.add_parser("uncertainty", help="nonspecificity, Deng's entropy and other uncertainty measures",
                       description="Uncertainty measures of one mass function, in bits: every measure "
                                   "defined under its model, or those named.")
    p.add_argument("bba", metavar="BBA.json")
    p.add_argument("--measure", nargs="+", action="extend", metavar="NAME",
                   help="only these measures (default: every measure defined under the model)")
    p.add_argument("--json", action="store_true", help="print JSON")
    _table_limit_options(p)
    p.set_defaults(func=_run_measuring, measuring=_cmd_uncertainty)

    p = sub.add_parser("plot", help="draw a mass function (needs the plot extra)",
                       description="Draw the masses, the Bel/BetP/Pls interval of every hypothesis and, for "
                                   "up to four hypotheses, the Hasse diagram of the focal elements.")
    p.add_argument("bba", metavar="BBA.json")
    p.add_argument("--out", required=True, metavar="FIG.png",
                   help="the picture to write, exactly there (its folder must exist); the format follows the "
                        "suffix (.png, .pdf, .svg, …), PNG without one")
    p.add_argument("--title", help="a title (default: the file name)")
    p.add_argument("--json", action="store_true", help='print {"file": FIG, "format": "png"} instead of "wrote FIG"')
    p.set_defaults(func=_cmd_plot)

    p = sub.add_parser("demo", help="a short demonstration on embedded data",
                       description="Fuse the evidence of an embedded example and print the results.")
    p.set_defaults(func=_cmd_demo)

    for ep in _command_plugins():
        try:
            ep.load()(sub)
        except Exception as exc:  # a broken plugin must not break the core commands
            print(f"belief: warning: plugin {ep.name!r} could not be loaded: {exc}", file=sys.stderr)
    # -q and -v go before the command or after it, on every command a plugin's included.
    _verbosity_options(parser, main_parser=True)
    for command in {id(c): c for c in sub.choices.values()}.values():
        _verbosity_options(command, main_parser=False)
    return parser


def _command_plugins() -> list:
    """The entry points of the command plugins, each named target once.

    An environment that held this project under an earlier distribution name lists the same entry points twice
    (once per distribution's metadata); loading both would register each command twice.
    """
    unique = {}
    for ep in entry_points(group=ENTRY_POINT_GROUP):
        unique.setdefault((ep.name, ep.value), ep)
    return list(unique.values())


def _verbosity_options(parser: argparse.ArgumentParser, main_parser: bool) -> None:
    """-q/--quiet and -v/--verbose on ``parser``.

    The main parser has the defaults; a command's parser none (``argparse.SUPPRESS``), so that an option given
    before the command is not overwritten by the command's default.  A parser that has its own -q or -v keeps it.
    """
    quiet = {} if main_parser else {"default": argparse.SUPPRESS}
    verbose = {"default": 0} if main_parser else {"default": argparse.SUPPRESS}
    try:
        parser.add_argument("-q", "--quiet", action="store_true",
                            help="print only the results and the errors: no progress bar, note or announcement",
                            **quiet)
        parser.add_argument("-v", "--verbose", action="count",
                            help="print details on standard error as well: the inputs read, the model, rule, "
                                 "representation and settings in effect, and the time taken",
                            **verbose)
    except argparse.ArgumentError:
        pass


# A message quotes user text, which may hold line breaks; escaped, the refusal stays one line.
_LINE_BREAKS = str.maketrans({c: c.encode("unicode_escape").decode("ascii")
                              for c in "\n\r\x0b\x0c\x1c\x1d\x1e\x85\u2028\u2029"})


def _one_line(message: str) -> str:
    return message.translate(_LINE_BREAKS)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit status."""
    _stdin["read"] = False
    _voice.update(level=0, command="")
    try:
        parser = build_parser()
        args = parser.parse_args(argv)
        if not getattr(args, "func", None):
            parser.print_help()
            return 2
        if getattr(args, "quiet", False) and getattr(args, "verbose", 0):
            raise CommandError(f"belief {args.command}: error: give -q (quiet) or -v (verbose), not both")
        _voice.update(level=verbosity(args), command=args.command)
        started = time.perf_counter()
        status = int(args.func(args) or 0)
        _detail(f"finished in {time.perf_counter() - started:.3f} s")
        return status
    except CommandError as exc:
        print(exc, file=sys.stderr)
        return 2
    except BeliefError as exc:
        print(f"belief: error: {_one_line(str(exc))}", file=sys.stderr)
        return 1
    except BrokenPipeError:
        return 0
    except KeyboardInterrupt:
        print("belief: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
