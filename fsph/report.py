"""`fsph report`: run the validation decks (or read the outputs of earlier
runs) and write a markdown table of every metric against its reference,
with the bar it is held to, the energy errors, wall times and pictures of
the Taylor rods.

The decks and their references are installed with the package
(fsph/cases, `installed_cases()`); `--cases DIR` reads another folder.

The bars live in the reference JSON files, beside the values:

    "acceptance": {"source": "...", "each_percent": 4.0, "residual_velocity_percent": 3.0}
    "acceptance_by_mode": {"source": "...", "sph": {"each_percent": 6.0}, "fem": {}}

A run in a mode that `acceptance_by_mode` names is held to that entry (an
empty entry: no bar), any other to `acceptance`. Within the entry a metric
KEY (group.KEY of the comparison, e.g. front_mm) has the bar
KEY_absolute (in the metric's unit), else STEM_percent (STEM: KEY without
its unit, front_mm -> front), else each_percent; without any, no bar."""

import json
import math
import re
from pathlib import Path

from . import deck as deck_module
from . import references
from .driver import run
from .errors import InputError
from .plot import deformed_shapes

#: The decks of the validation report, in order (installed with the
#: package: meson.build installs each and its reference into fsph/cases).
VALIDATION_DECKS = ("elastic_bar", "elastic_bar_sph", "elastic_bar_coupled",
                    "taylor_armco_fem", "taylor_armco_sph", "taylor_armco")

#: The units a metric's key may end in, as written in a bar.
UNITS = {"mm": "mm", "m_s": "m/s", "GPa": "GPa", "MPa": "MPa", "kg": "kg", "J": "J"}
_UNIT = re.compile(r"_(" + "|".join(UNITS) + r")$")


def installed_cases():
    """The folder of the validation decks installed with fsph (fsph/cases);
    from a source checkout that is not installed, the checkout's cases/."""
    package = Path(__file__).resolve().parent
    if not (package / "cases").is_dir() and (package.parent / "meson.build").is_file():
        return package.parent / "cases"
    return package / "cases"


def _inputs_now(deck_path):
    """The digests of the deck and of its reference as they are now
    (references.run_inputs, as a run stores them in summary.json)."""
    deck = deck_module.load(deck_path)
    return references.run_inputs(Path(deck_path).read_text(), references.load(deck))


def stale_because(deck_path, summary):
    """Why a stored summary is not a result of the deck as it is now ("" when
    it is): a run that was killed ('running'), one that does not record
    its inputs (from before they were recorded), or a deck or reference
    changed since (their digests, summary.json inputs: as fsph.sweep
    tells a changed variant deck by its text's digest)."""
    if not isinstance(summary, dict) or "status" not in summary:
        return "its summary.json is not a run's summary"
    if summary["status"] == "running":
        return "the run there did not finish"
    stored = summary.get("inputs")
    if not isinstance(stored, dict):
        return "the run there does not record its deck"
    now = _inputs_now(deck_path)
    if stored.get("deck_sha256") != now["deck_sha256"]:
        return f"{deck_path} changed since that run"
    if stored.get("reference_sha256") != now["reference_sha256"]:
        return f"the reference of {deck_path} changed since that run"
    return ""


def _summary(deck, outdir, rerun, say):
    """The summary of the deck's run in outdir: the stored one where it is
    a result of the deck as it is now (stale_because), else (or with
    rerun) a new run's, saying why a stored run is not reused."""
    summary_path = outdir / "summary.json"
    if not rerun and summary_path.is_file():
        try:
            summary = json.loads(summary_path.read_text())
        except (OSError, ValueError):
            summary = None
        why = stale_because(deck, summary)
        if not why:
            return summary
        say(f"fsph report: {outdir}: {why}; running it again")
    return run(deck, outdir, quiet=True)


def _bad_bar(deck, where, value):
    return InputError(f"{deck}: the reference's {where}: expected a non-negative number, got "
                      f"{value!r}")


def acceptance(reference, mode, deck="the deck"):
    """The reference's bars for a run in `mode`: its acceptance_by_mode
    entry if it names the mode, else its acceptance ({} without)."""
    by_mode = reference.get("acceptance_by_mode", {})
    block = by_mode.get(mode) if isinstance(by_mode, dict) and mode in by_mode \
        else reference.get("acceptance", {})
    if not isinstance(block, dict):
        raise InputError(f"{deck}: the reference's acceptance for mode {mode}: expected a JSON "
                         f"object of bars, got {block!r}")
    return block


def bar(block, key, deck="the deck"):
    """The bar of metric `key` in an acceptance block: ('absolute', value)
    in the metric's unit, ('percent', value), or None."""
    m = _UNIT.search(key)
    stem = key[:m.start()] if m else key
    for name, kind in ((f"{key}_absolute", "absolute"), (f"{stem}_percent", "percent"),
                       ("each_percent", "percent")):
        if name in block:
            value = block[name]
            if isinstance(value, bool) or not isinstance(value, (int, float)) \
                    or not math.isfinite(value) or value < 0:
                raise _bad_bar(deck, name, value)
            return kind, float(value)
    return None


def _unit(key):
    """The unit of a metric, from its key ('' without)."""
    m = _UNIT.search(key)
    return UNITS[m.group(1)] if m else ""


def _bar_text(kind_value, key):
    kind, value = kind_value
    return f"{value:g} %" if kind == "percent" else f"{value:g} {_unit(key)}".rstrip()


def within(kind_value, comparison):
    """Whether a comparison entry (computed, reference, error_percent)
    meets the bar (a metric the run did not measure does not)."""
    kind, value = kind_value
    if comparison["computed"] is None:
        return False
    if kind == "percent":
        return abs(comparison["error_percent"]) <= value
    return abs(comparison["computed"] - comparison["reference"]) <= value


def _acceptance_of(deck_path, mode):
    """The acceptance block of the deck's reference for `mode` ({} without
    a reference)."""
    deck = deck_module.load(deck_path)
    reference = references.load(deck)
    return acceptance(reference, mode, deck_path) if reference is not None else {}


def _compared(name, metric, c, kind_value):
    """A metric of case `name` against its reference (c: its comparison
    entry) and its bar (kind_value: bar(); None without): the result the
    summary line counts and the table's cells from fsph to within bar."""
    key = metric.split(".", 1)[1]
    measured = c["computed"] is not None
    why = c.get("not_measured_because")
    error = f"{c['error_percent']:+.2f} %" if measured else \
        "not measured" + (f" ({why})" if why else "")
    result = {"case": name, "metric": metric, "error": error, "bar": None, "within": None}
    if kind_value is not None:
        result.update(bar=_bar_text(kind_value, key), within=within(kind_value, c))
        if kind_value[0] == "absolute" and measured:    # the difference in the bar's unit
            error += f" ({c['computed'] - c['reference']:+.3g} {_unit(key)})".replace(" )", ")")
            result["error"] = error
    verdict = "–" if result["within"] is None else ("yes" if result["within"] else "NO")
    computed = f"{c['computed']:.4g}" if measured else "none"
    return result, (f"{computed} | {c['reference']:.4g} | {error} | {result['bar'] or 'none'} | "
                    f"{verdict}")


def _uncompared(summary):
    """Why a run has no metric against a reference: (the table's cell,
    the summary line's words): no reference named by its deck, one whose
    conditions do not hold for the run (not compared, and why), or one
    with no value of what the run measures; None where it has some."""
    ref = summary.get("reference")
    if ref is None:
        return "no reference", "no reference"
    if not ref.get("applies", True):
        return "not compared", f"not compared: {ref.get('not_applied_because', '')}"
    if not any(ref.get("comparison", {}).values()):
        return "nothing compared", "the reference has none of its metrics"
    return None


def _measured(summary):
    """The numbers a run measured (summary.json metrics, the series left
    out): a list of (GROUP.KEY, value)."""
    return [(f"{group}.{key}", value) for group, values in summary.get("metrics", {}).items()
            if group != "series" and isinstance(values, dict)
            for key, value in values.items()
            if isinstance(value, (int, float)) and not isinstance(value, bool)]


def _summary_line(results, unfinished, uncompared=()):
    """'N of M metrics within their bars', the failures, the metrics
    without a bar, the runs without a comparison with a reference and the
    runs that did not complete."""
    held = [r for r in results if r["bar"] is not None]
    outside = [r for r in held if not r["within"]]
    text = f"{len(held) - len(outside)} of {len(held)} metrics within their bars"
    if outside:
        text += "; outside: " + ", ".join(
            f"{r['case']} {r['metric']} ({r['error']}, bar {r['bar']})" for r in outside)
    else:
        text += "."
    lines = [text]
    free = [r for r in results if r["bar"] is None]
    if free:
        lines.append(f"Without a bar ({len(free)}): "
                     + ", ".join(f"{r['case']} {r['metric']} ({r['error']})" for r in free) + ".")
    if uncompared:
        lines.append(f"Without a reference ({len(uncompared)}): "
                     + ", ".join(f"{name} ({why})" for name, why in uncompared) + ".")
    if unfinished:
        lines.append("Not completed: " + ", ".join(f"{name} ({status})"
                                                   for name, status in unfinished) + ".")
    return lines


def write_report(cases_dir, output_dir, decks=VALIDATION_DECKS, rerun=False, say=None):
    """Run (or reuse) each deck's outputs under output_dir/runs/<deck> and
    write output_dir/report.md; returns its path (make_report)."""
    return make_report(cases_dir, output_dir, decks, rerun, say)[0]


def make_report(cases_dir, output_dir, decks=VALIDATION_DECKS, rerun=False, say=None):
    """Run each deck into output_dir/runs/<deck>, or reuse the run there
    where it is of the deck and reference as they are now (stale_because;
    say(line) tells why one is run again), and write output_dir/report.md
    and report.html: a row per metric compared with a reference, per
    metric measured by a run without a comparison (saying why), and a
    status row for a run that did not complete or measured nothing.
    Returns (report.md's path, {deck: its run's status})."""
    say = say or (lambda line: None)
    cases_dir, output_dir = Path(cases_dir), Path(output_dir)
    try:
        output_dir.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise InputError(f"{output_dir}: cannot make the report folder: {err.strerror or err}") \
            from None
    table = ["| case | mode | quantity | fsph | reference | error | bar | within bar "
             "| energy (end / largest) | cycles | wall [s] | warnings |",
             "|---|---|---|---:|---:|---:|---:|---|---|---:|---:|---|"]
    pictures, results, unfinished, uncompared, statuses = [], [], [], [], {}
    for name in decks:
        deck = cases_dir / f"{name}.nml"
        outdir = output_dir / "runs" / name
        summary = _summary(deck, outdir, rerun, say)
        statuses[name] = summary["status"]
        block = _acceptance_of(deck, summary["mode"])
        energy = summary["energy"]
        e_text = (f"{100 * energy['relative_error']:+.2f} % / "
                  f"{100 * energy.get('max_relative_error', energy['relative_error']):+.2f} %")
        flags = "; ".join(f"**{w['kind']}**: {w['message']}" for w in summary.get("warnings", []))
        tail = f"{e_text} | {summary['cycles']} | {summary['wall_time_s']:.1f} | {flags} |"
        comparison = summary.get("reference", {}).get("comparison", {})
        rows = [(group, key, c) for group, values in comparison.items()
                for key, c in values.items()]
        why = None if rows else _uncompared(summary)
        own = _measured(summary) if why else []
        if why:
            uncompared.append((name, why[1]))
        if summary["status"] != "completed":
            unfinished.append((name, summary["status"]))
        if summary["status"] != "completed" or not (rows or own):
            table.append(f"| {name} | {summary['mode']} | status | {summary['status']} | "
                         f"{why[0] if why else ''} | | | | {tail}")
        for metric, value in own:
            table.append(f"| {name} | {summary['mode']} | {metric} | {value:.4g} | {why[0]} | – "
                         f"| none | – | {tail}")
        for group, key, c in rows:
            result, cells = _compared(name, f"{group}.{key}", c, bar(block, key, deck))
            results.append(result)
            table.append(f"| {name} | {summary['mode']} | {group}.{key} | {cells} | {tail}")
        if "taylor" in summary.get("metrics", {}):
            png = deformed_shapes(outdir, output=output_dir / f"{name}.png", dpi=80)
            pictures.append((name, png.name))
    head = _summary_line(results, unfinished, uncompared)
    lines = ["# fsph validation report", ""] + head + [
        "", f"Generated by `fsph report` from the decks in `{cases_dir}`; each row is a metric "
        "of a case against its reference (`references/` beside the decks) and the bar the "
        "reference holds it to (its `acceptance`, per mode `acceptance_by_mode`; none: no "
        "accuracy bar); a case without a comparison (no reference, or one whose conditions "
        "do not hold) lists what it measured.", ""] + table + [""]
    for name, png in pictures:
        lines += [f"## {name}", "", f"![{name}]({png})", ""]
    path = output_dir / "report.md"
    path.write_text("\n".join(lines))
    (output_dir / "report.html").write_text(_html(head, table, pictures))
    return path, statuses


def _cells(row):
    """The cells of a markdown table row."""
    return [c.strip() for c in row.strip().strip("|").split("|")]


def _inline(text):
    """Markdown's **bold** and `code` of a cell or line as HTML (escaped)."""
    import html
    import re
    text = html.escape(text)
    text = re.sub(r"\*\*(.+?)\*\*", r"<b>\1</b>", text)
    return re.sub(r"`(.+?)`", r"<code>\1</code>", text)


def _html(summary_lines, table, pictures):
    """report.html: the summary, the table (rows outside their bar in red)
    and the pictures beside it."""
    head, body = _cells(table[0]), [_cells(r) for r in table[2:]]
    verdict = head.index("within bar")
    rows = "\n".join(
        "<tr{}>{}</tr>".format(' class="no"' if cells[verdict] == "NO" else "",
                               "".join(f"<td>{_inline(c)}</td>" for c in cells)) for cells in body)
    figures = "\n".join(f'<figure><img src="{png}" alt="{name}"><figcaption>{name}</figcaption></figure>'
                         for name, png in pictures)
    summary = "\n".join(f"<p>{_inline(line)}</p>" for line in summary_lines if line.strip())
    return f"""<!DOCTYPE html>
<html><head><meta charset="utf-8"><title>fsph validation report</title>
<style>
body {{ font-family: sans-serif; margin: 1.5em; }}
.page {{ display: flex; gap: 2em; align-items: flex-start; flex-wrap: wrap; }}
table {{ border-collapse: collapse; font-size: 0.85em; }}
td, th {{ border: 1px solid #ccc; padding: 0.2em 0.5em; }}
tr.no td {{ background: #fdd; }}
figure {{ margin: 0 0 1em 0; }} img {{ max-width: 520px; }}
</style></head>
<body><h1>fsph validation report</h1>
{summary}
<div class="page"><table>
<tr>{"".join(f"<th>{_inline(h)}</th>" for h in head)}</tr>
{rows}
</table>
<div>{figures}</div></div>
</body></html>
"""
