"""One HTML page per study (``figures/index.html``), self-contained next to its images.

The page says what was run and what came out: the study's description and file, the robot
(its joint motor's rotor when it has one), the gait and integrator its steps ran (or what a
step that runs no gait ran instead), then every step in the study's order with its key
numbers (what its step kind reports of its dataset, :meth:`~monkeystudy.study.steps.base.
StepKind.describe`), a link to its dataset and its figures, each with the caption of its
drawing (what to look at), or for a figure with nothing to show, why it was not drawn; last,
the provenance of every dataset. It links only to files beside it (the figures) and one
folder up (the datasets), so the study folder can be moved or zipped whole.
"""
from __future__ import annotations

import html
import json
import re
from pathlib import Path
from typing import Mapping, Sequence

from ruamel.yaml import YAML, YAMLError

from .. import __version__
from ..study.failures import FAILED, StepFailure
from ..study.figures import figure_name
from ..study.progress import count, singular_counts
from ..study.steps import REGISTRY
from .common import PAGE_WIDTH_PX
from .drawing import Drawing

PAGE = "index.html"

STYLE = """
body { font: 15px/1.45 system-ui, -apple-system, "Segoe UI", sans-serif; color: #1b1b1b;
       max-width: {page_width}px; margin: 2em auto; padding: 0 1.5em; }
h1 { font-size: 1.7em; margin-bottom: 0.1em; } h2 { margin-top: 2em; border-bottom: 1px solid #ccc; }
h3 { margin-top: 1.6em; } h3 small { color: #666; font-weight: normal; }
table { border-collapse: collapse; margin: 0.5em 0; } td, th { padding: 0.2em 0.8em;
       border-bottom: 1px solid #e4e4e4; text-align: left; vertical-align: top; }
th { color: #555; font-weight: 600; }
pre { background: #f6f6f6; padding: 0.8em; overflow-x: auto; font-size: 13px; }
ul.numbers { font-family: ui-monospace, "DejaVu Sans Mono", monospace; font-size: 13px;
             padding-left: 1.2em; }
figure { margin: 1.2em 0 2em; } figure img, figure video { max-width: 100%; border: 1px solid #ddd; }
figcaption { font-size: 14px; color: #333; margin-top: 0.3em; }
nav { display: flex; flex-wrap: wrap; gap: 0.2em 1em; } .muted { color: #666; font-size: 13px; }
.skipped { border: 1px dashed #bbb; padding: 0.8em 1em; background: #fafafa; }
.skipped p { margin: 0 0 0.3em; }
.failed { border-left: 4px solid #c0392b; padding: 0.4em 0.8em; background: #fdf2f1; }
""".replace("{page_width}", str(PAGE_WIDTH_PX))


def _e(text) -> str:
    return html.escape(str(text), quote=True)


def _prose(text) -> str:
    """Escaped text with the docstrings' ``literal`` markup as <code>."""
    return re.sub(r"``(.+?)``", r"<code>\1</code>", _e(text))


def _json(attrs: Mapping, name: str):
    try:
        return json.loads(attrs.get(name, ""))
    except (TypeError, ValueError):
        return None


#: a value that is not a number, with the unit that would follow it
_NOT_A_NUMBER = re.compile(r"\bnan\b(?: (?:rad s-1|rad|m|s|J|N m|kg|%))?", re.IGNORECASE)


def tidy(line: str) -> str:
    """A key-number line as the page shows it: a value that is not a number as "–" (its unit
    dropped), a count of one in the singular."""
    line = _NOT_A_NUMBER.sub("–", line)
    return singular_counts(line)


def description(doc: str | None, settings: Mapping | None = None) -> str:
    """A step kind's description for the page: the first sentence of its model's docstring,
    whole (the docstring's first line may stop mid-sentence), on one line. A numeric
    setting it names (````cycles````) reads as the step's value in ``settings``
    (``for 30 cycles``), a count of one in the singular."""
    para = re.split(r"\n\s*\n", (doc or "").strip(), maxsplit=1)[0]
    text = " ".join(para.split())
    # a sentence ends at ". " before a capital or markup, never inside ``literal`` text
    ends = [m.end(1) for m in re.finditer(r"(\.)\s+(?=[A-Z`(])", text)
            if text[:m.start()].count("``") % 2 == 0]
    text = text[:ends[0]] if ends else text
    if not settings:
        return text

    def value(m):
        v = settings.get(m.group(1))
        number = isinstance(v, (int, float)) and not isinstance(v, bool)
        return f"{v:g}" if number else m.group(0)
    return singular_counts(re.sub(r"``(\w+)``", value, text))


def step_settings(datasets: Mapping[str, object],
                  failures: Mapping[str, StepFailure] | None = None) -> dict[str, dict]:
    """Each step's settings as the study last run wrote them (:func:`study_steps`' study
    text), the defaults of its kind's settings under them: ``{name: {key: value}}``."""
    out = {}
    for name, entry in _newest_steps(datasets, failures).items():
        kind = REGISTRY.get(str(entry.get("kind")))
        defaults = {} if kind is None else {
            key: f.default for key, f in kind.model.model_fields.items()
            if isinstance(f.default, (int, float, str))}
        out[name] = {**defaults, **entry}
    return out


#: the time at the start of a dataset's ``history`` (ISO 8601)
_WHEN = re.compile(r"^\d{4}-\d\d-\d\dT[\d:.]+(?:[+-]\d\d:\d\d|Z)?")


def study_steps(datasets: Mapping[str, object],
                failures: Mapping[str, StepFailure] | None = None) -> dict[str, str]:
    """The steps of the study as last run, ``{name: kind}`` in the study file's order: those
    of the newest study text among the datasets (``study_text``, dated by ``history``) and
    the failure markers of the folder's last run (dated by ``time``). The text is read as
    YAML, not validated (a study run by an earlier version may break a newer rule). Empty
    when no study text can be read."""
    return {name: str(entry.get("kind", "?"))
            for name, entry in _newest_steps(datasets, failures).items()}


def _newest_steps(datasets: Mapping[str, object],
                  failures: Mapping[str, StepFailure] | None = None) -> dict[str, dict]:
    """``{name: settings}`` of the steps of the newest study text (:func:`study_steps`)."""
    texts: list[tuple[str, str]] = []
    for ds in datasets.values():
        text = ds.attrs.get("study_text")
        m = _WHEN.match(str(ds.attrs.get("history", "")))
        if text:
            texts.append((m.group(0) if m else "", text))
    texts += [(f.time, f.study_text) for f in (failures or {}).values() if f.study_text]
    for _, text in sorted(texts, key=lambda t: t[0], reverse=True):
        steps = _named_steps(text)
        if steps:
            return steps
    return {}


def _named_steps(text: str) -> dict[str, dict]:
    """``{name: settings}`` of the steps of a study file's text (empty if it cannot be
    read)."""
    try:
        data = YAML(typ="safe").load(text)
        return {str(s["name"]): dict(s) for s in data["steps"]}
    except (YAMLError, TypeError, KeyError, AttributeError, ValueError):
        return {}


def step_order(datasets: Mapping[str, object],
               failures: Mapping[str, StepFailure] | None = None) -> list[str]:
    """Every step of the study as last run (:func:`study_steps`) in the study file's order,
    with a dataset or not, then any other datasets by name."""
    names = list(study_steps(datasets, failures))
    return names + sorted(set(datasets) - set(names))


def missing_steps(datasets: Mapping[str, object],
                  failures: Mapping[str, StepFailure] | None = None) -> dict[str, str]:
    """The steps of the study as last run that have no dataset, each with what became of
    it: its failure marker's ``failed: <reason>`` or ``not run: <reason>``, or ``no
    dataset`` (not run yet, or interrupted)."""
    failures = failures or {}
    out = {}
    for name in study_steps(datasets, failures):
        if name in datasets:
            continue
        f = failures.get(name)
        out[name] = (f"{'failed' if f.state == FAILED else 'not run'}: {f.reason}" if f
                     else "no dataset: not run yet, or its run was interrupted")
    return out


def _num(value) -> str:
    """A robot parameter as a person reads it: ten significant digits at most (a preset's
    inertia computed as m L^2 / 12 would print its binary round-off)."""
    return f"{value:.10g}" if isinstance(value, float) else str(value)


def _robot_table(robot: Mapping) -> str:
    links = (("link1", "link 1 (end A)"), ("link2", "link 2 (end B)"))
    # a robot whose CGs lie off its links' lines (docs/model.md section 1) shows their offsets
    across = any(robot.get(key, {}).get("com_across") for key, _ in links)
    rows = []
    for key, label in links:
        lk = robot.get(key, {})
        rows.append(f"<tr><td>{_e(label)}</td><td>{_num(lk.get('mass'))} kg</td>"
                    f"<td>{_num(lk.get('length'))} m</td><td>{_num(lk.get('com'))} m</td>"
                    + (f"<td>{_num(lk.get('com_across', 0.0))} m</td>" if across else "")
                    + f"<td>{_num(lk.get('inertia'))} kg m²</td></tr>")
    friction = []
    for key, label in (("pivot_friction", "pivot"), ("joint_friction", "joint")):
        f = robot.get(key) or {}
        if f.get("viscous") or f.get("coulomb"):
            friction.append(f"{label}: viscous {f.get('viscous')} N m s, Coulomb "
                            f"{f.get('coulomb')} N m")
    return ("<table><tr><th></th><th>mass</th><th>length</th><th>CG from its proximal end</th>"
            + ("<th>CG across the link (counter-clockwise)</th>" if across else "")
            + "<th>inertia about the CG</th></tr>" + "".join(rows) + "</table>"
            f"<p>gravity {robot.get('gravity')} m s⁻²; friction: "
            f"{_e('; '.join(friction) or 'none')}</p>" + _rotor_text(robot.get("rotor")))


def _rotor_text(rotor) -> str:
    """The joint motor's rotor of a robot attribute (``Robot.to_dict()``'s ``rotor``:
    inertia [kg m2], gear_ratio [1], housing 1 or 2) in words, with the inertia it reflects to
    the joint, N² I_r (docs/model.md section 2); empty when the robot has none."""
    if not isinstance(rotor, Mapping):
        return ""
    try:
        inertia, ratio = float(rotor["inertia"]), float(rotor["gear_ratio"])
        housing = int(rotor["housing"])
    except (KeyError, TypeError, ValueError):
        return "<p>" + _e(f"joint motor's rotor: {json.dumps(rotor, sort_keys=True)}") + "</p>"
    end = {1: "link 1 (end A)", 2: "link 2 (end B)"}.get(housing, f"link {housing}")
    if inertia == 0.0:     # the geometry alone, for a step that identifies the inertia
        return ("<p>" + _e(f"joint motor's rotor: gear ratio {_num(ratio)} (rotor turns per "
                           f"turn of the joint), its housing on {end}; its inertia not given "
                           "(0 kg m²)") + "</p>")
    return ("<p>" + _e(f"joint motor's rotor: inertia {_num(inertia)} kg m² about its axis, "
                       f"gear ratio {_num(ratio)} (rotor turns per turn of the joint), "
                       "reflected to the joint N² I")
            + "<sub>r</sub>" + _e(f" = {_num(ratio * ratio * inertia)} kg m²; its housing on "
                                  f"{end}") + "</p>")


def _figure_html(name: str, outputs: Sequence[str], title: str, caption: str) -> str:
    stills = [o for o in outputs if o.endswith((".png", ".svg"))]
    videos = [o for o in outputs if o.endswith(".mp4")]
    gifs = [o for o in outputs if o.endswith(".gif")]
    others = [o for o in outputs if o not in stills + videos + gifs]
    if stills:
        body = f'<a href="{_e(stills[0])}"><img src="{_e(stills[0])}" alt="{_e(title)}"></a>'
    elif videos:
        body = f'<video controls preload="metadata" src="{_e(videos[0])}"></video>'
    elif gifs:
        body = f'<img src="{_e(gifs[0])}" alt="{_e(title)}">'
    else:
        body = ""
    links = " ".join(f'<a href="{_e(o)}">{_e(Path(o).suffix[1:].upper())}</a>'
                     for o in stills[1:] + videos + gifs + others if o)
    return (f'<figure id="{_e(name)}">{body}<figcaption><b>{_e(title)}.</b> {_prose(caption)}'
            + (f' <span class="muted">({links})</span>' if links else "")
            + "</figcaption></figure>")


def _skipped_html(name: str, title: str, caption: str, reason: str) -> str:
    return (f'<figure id="{_e(name)}" class="skipped"><p><b>{_e(title)}</b>: not drawn, '
            f"{_prose(reason)}.</p><figcaption class=\"muted\">{_prose(caption)}</figcaption>"
            "</figure>")


#: the step-size controllers an integrator names, in words
STEP_CONTROLLERS = {"scipy": "scipy's step-size control", "pi": "a PI step-size control"}


def gait_text(gait: Mapping) -> str:
    """The study's gait settings in words, with units."""
    parts = [str(gait.get("kind", "?"))]
    if "motor_torque" in gait:
        parts.append(f"motor torque {float(gait['motor_torque']):g} N m")
    if "tick" in gait:
        tick = float(gait["tick"])
        parts.append("exact event timing" if tick == 0 else f"controller tick {tick * 1e3:g} ms")
    frames = {"motor": "torques in the motor frame (the physical motor torque, its sign "
                       "fixed to the links over each cycle)",
              "attached_end": "torques on theta2 of the attached end's frame"}
    if "torque_frame" in gait:
        parts.append(frames.get(str(gait["torque_frame"]), f"torque_frame {gait['torque_frame']}"))
    parts += [f"{k} {v}" for k, v in gait.items() if k not in ("kind", "motor_torque", "tick",
                                                                "torque_frame")
              and not isinstance(v, (list, dict))]
    return ", ".join(parts)


def integrator_text(integ: Mapping) -> str:
    """The integrator settings in words, with units: the method, its tolerances, the horizon
    of a controller segment and the step-size control (not a controller of the robot)."""
    parts = [str(integ.get("method", "?")).upper()]
    for key in ("rtol", "atol"):
        if key in integ:
            parts.append(f"{key} {float(integ[key]):.0e}")
    if "max_time" in integ:
        parts.append(f"at most {float(integ['max_time']):g} s per controller segment")
    if "controller" in integ:
        parts.append(STEP_CONTROLLERS.get(str(integ["controller"]),
                                          f"{integ['controller']} step-size control"))
    return ", ".join(parts)


def _own_setup(datasets: Mapping[str, object], kinds: Mapping[str, str], names: Sequence[str],
               runs_gait: bool) -> list[str]:
    """The set-up's sentences on the steps ``names`` that do not run the study's gait: what
    each ran instead and with which integrator (its kind's :meth:`~monkeystudy.study.steps.
    base.StepKind.own_setup` of its dataset)."""
    if not names:
        return []
    head = ("These steps do not run the gait above: " if runs_gait else
            "No step of this study runs the study's gait: ")
    parts = []
    for n in names:
        text = REGISTRY[kinds[n]].own_setup(datasets[n])
        parts.append(f'<a href="#step-{_e(n)}">{_e(n)}</a> [{_e(kinds[n])}] '
                     + _e(text or "runs its own"))
    return ["<p>" + _e(head) + "; ".join(parts) + ".</p>"]


def render_page(study_dir: Path, datasets: Mapping[str, object],
                figures: Mapping[str, Sequence[str]],
                skipped: Mapping[str, str] | None = None,
                failures: Mapping[str, StepFailure] | None = None, *,
                drawings: Mapping[tuple[str, str], Drawing]) -> str:
    """The page's HTML for the datasets of a study folder (``{step name: xarray Dataset}``),
    the figures drawn from them (``{figure name: [file names]}``), those skipped with
    nothing to show (``{figure name: reason}``) and the failure markers of its last run
    (``{step name: StepFailure}``): every step of the study is listed, a step without a
    dataset with what became of it. ``drawings`` (by ``(step kind, figure suffix)``) give
    each figure's title and caption."""
    skipped = dict(skipped or {})
    failures = dict(failures or {})
    kinds = study_steps(datasets, failures)
    settings = step_settings(datasets, failures)
    order = step_order(datasets, failures)
    missing = missing_steps(datasets, failures)
    first = next((datasets[n].attrs for n in order if n in datasets), None)
    if first is None:      # every step failed: the study as its markers record it
        f = next(iter(failures.values()), None)
        first = {"study_name": f.study_name, "study_text": f.study_text} if f else {}
    study = first.get("study_name", Path(study_dir).name)
    robot = _json(first, "robot") or {}
    gait = _json(first, "gait") or {}
    integ = _json(first, "integrator") or {}
    # the study's gait and integrator are what its steps ran unless no step runs them
    # (StepKind.runs_gait); a study text that cannot be read: as the dataset records them
    runs_gait = (any(getattr(REGISTRY.get(k), "runs_gait", True) for k in kinds.values())
                 if kinds else bool(gait))
    own = [n for n in order if n in datasets and n in kinds and kinds[n] in REGISTRY
           and not REGISTRY[kinds[n]].runs_gait]
    out = [f"<!doctype html><html lang='en'><head><meta charset='utf-8'>"
           f"<title>{_e(study)}: monkeystudy</title><style>{STYLE}</style></head><body>",
           f"<h1>Study <code>{_e(study)}</code></h1>",
           f"<p>{_e(first.get('study_description', ''))}</p>",
           "<nav>" + "".join(f'<a href="#step-{_e(n)}">{_e(n)}</a>' for n in order)
           + '<a href="#provenance">provenance</a></nav>',
           "<h2>Set-up</h2>",
           f"<p>Robot <code>{_e(robot.get('name', '?'))}</code>:</p>", _robot_table(robot),
           *(["<p>Gait: " + _e(gait_text(gait)) + ". Integrator: "
              + _e(integrator_text(integ)) + ".</p>"] if runs_gait else []),
           *_own_setup(datasets, kinds, own, runs_gait),
           "<details><summary>study file</summary><pre>"
           + _e(first.get("study_text", "")) + "</pre></details>",
           "<h2>Steps</h2>"]
    if missing:
        out.append('<p class="failed">' + _e(f"{len(missing)} of {count(len(kinds), 'step')} "
                                             f"{'has' if len(missing) == 1 else 'have'} no "
                                             "dataset: ")
                   + ", ".join(f'<a href="#step-{_e(n)}">{_e(n)}</a>' for n in missing)
                   + ".</p>")
    used: set[str] = set()
    for name in order:
        if name in missing:
            kind = REGISTRY.get(kinds[name])
            out.append(f'<h3 id="step-{_e(name)}">{_e(name)} <small>[{_e(kinds[name])}]'
                       f'</small></h3>')
            if kind is not None:
                out.append("<p>" + _prose(description(kind.model.__doc__, settings.get(name)))
                           + "</p>")
            out.append(f'<p class="failed">{_e(missing[name].rstrip("."))}.</p>')
            continue
        ds = datasets[name]
        kind = REGISTRY.get(ds.attrs.get("step_kind"))
        kind_name = kind.name if kind else ds.attrs.get("step_kind", "?")
        out.append(f'<h3 id="step-{_e(name)}">{_e(name)} <small>[{_e(kind_name)}]'
                   f'</small></h3>')
        if name in failures:
            f = failures[name]
            what = ("The last run of this step failed" if f.state == FAILED else
                    "The last run did not run this step")
            out.append('<p class="failed">' + _e(f"{what}: {f.reason.rstrip('.')}. Its "
                                                 "dataset below is of an earlier run.")
                       + "</p>")
        if kind is not None:
            out.append("<p>" + _prose(description(kind.model.__doc__, settings.get(name)))
                           + "</p>")
            try:
                lines = kind.describe(ds)
            except Exception as exc:   # a dataset of another version: still show the rest
                lines = [f"(key numbers unavailable: {type(exc).__name__}: {exc})"]
            if lines:
                out.append('<ul class="numbers">' + "".join(f"<li>{_e(tidy(x))}</li>"
                                                            for x in lines)
                           + "</ul>")
        out.append(f'<p class="muted">dataset <a href="../{_e(name)}.nc">{_e(name)}.nc</a>'
                   "</p>")
        for fig in (kind.figures if kind else ()):
            if fig.across:
                continue            # under "Across steps"
            key = figure_name(fig, name, kind.name)
            how = drawings[(kind.name, fig.suffix)]
            if key in figures:
                out.append(_figure_html(key, figures[key], how.title, how.caption))
                used.add(key)
            elif key in skipped:
                out.append(_skipped_html(key, how.title, how.caption, skipped[key]))
                used.add(key)
    across = [(kind, fig) for kind in REGISTRY.values() for fig in kind.figures if fig.across
              and figure_name(fig, "", kind.name) in set(figures) | set(skipped)]
    if across:
        out.append("<h2>Across steps</h2>")
        for kind, fig in across:
            key = figure_name(fig, "", kind.name)
            how = drawings[(kind.name, fig.suffix)]
            if key in figures:
                out.append(_figure_html(key, figures[key], how.title, how.caption))
            else:
                out.append(_skipped_html(key, how.title, how.caption, skipped[key]))
            used.add(key)
    rest = sorted(set(figures) - used)
    if rest:
        out.append("<h2>Other figures</h2>")
        out += [_figure_html(k, figures[k], k, "") for k in rest]
    out.append('<h2 id="provenance">Provenance</h2><table><tr><th>dataset</th><th>monkeystudy'
               "</th><th>git revision</th><th>code sha256</th><th>made</th></tr>")
    for name in (n for n in order if n in datasets):
        a = datasets[name].attrs
        out.append(f"<tr><td>{_e(name)}.nc</td><td>{_e(a.get('monkeystudy_version', ''))}</td>"
                   f"<td><code>{_e(str(a.get('git_revision', ''))[:14])}</code></td>"
                   f"<td><code>{_e(str(a.get('code_sha256', ''))[:12])}</code></td>"
                   f"<td>{_e(a.get('history', ''))}</td></tr>")
    libs = _json(first, "library_versions") or {}
    out.append("</table><p class='muted'>libraries: "
               + _e(", ".join(f"{k} {v}" for k, v in sorted(libs.items())))
               + f"; page drawn by monkeystudy {_e(__version__)}</p></body></html>\n")
    return "\n".join(out)
