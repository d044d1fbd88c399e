"""Draw every figure a study folder's datasets support, redrawing only what changed.

``report_study(DIR)`` reads the study's ``*.nc`` datasets (docs/datasets.md; classified by
their ``step_kind`` attribute), plans the figures they support and writes each as PNG and PDF
(the animation as MP4, or GIF without ffmpeg) into ``DIR/figures/``. It never simulates.
The figures are drawn on one process per core (:mod:`monkeystudy.plotting.workers`), the
longest first (the animations, by each drawing's ``cost``); every file is written to a temporary name and
renamed into place, so an interrupted report leaves no half-written file.

A figure whose datasets hold nothing it could show (:class:`~.drawing.NothingToDraw`: a
swap-time map without a single gait, a replay that fell in its first cycle) is *skipped*: the
log line and the study's page say why, and it is not a failure.

A manifest, ``DIR/figures/manifest.json``, records per figure the SHA-256 of each input
dataset, a hash of the plotting code and style file, the drawing options, and the files
written (or why it was skipped). A figure is redrawn only when one of those changed or one of
its files is missing, so a second call on unchanged datasets writes nothing, and a report
interrupted by Ctrl-C redoes only what it had not finished. Figures whose datasets were
deleted are removed.

=======================================  ======================================  ==============
file (``figures/``)                      what                                    study figure
=======================================  ======================================  ==============
``<grid>_surface``                       sqrt(error) surface, no-gait floor      3
``<grid>_map``                           error map truncated at 5, minima, the   4, 9, 10
                                         grid's least error
``<grid>_swap_time``                     swap time over the grid                 -
``<refine>_convergence``                 best-vertex error per iteration (0:     (text 4.2)
                                         the start)
``<stability>_error``                    error per cycle, log scale              5, 8
``<stability>_kinetic_energy``           kinetic energy per cycle                6
``<stability>_height``                   attached-end height per cycle           7
``<stability>_filmstrip``                one gait cycle, frame by frame          2 (from data)
``<stability>_animation``                the whole run (MP4, or GIF)             -
``<stability>_ladder``                   a bar gait's first 3 cycles on its      -
                                         ladder (MP4, or GIF)
``stability_error_comparison``           all multi-cycle runs' errors            5 + 8
``<shoot>_newton``                       residual norm per Newton iteration      -
``<floquet>_multipliers``                multipliers and the unit circle         -
``<tick_sweep>_error_growth``            error per cycle per tick, |lambda|^2n   -
``<basin>_cycles_map``                   cycles to failure around the gait       -
``<continuation>_branch``                gait family, |lambda| along it          -
``<work_precision>_work_precision``      wall time per gait against error        -
``<stress>_stress``                      energy drift, long runs, extreme cases  -
``<design>_map``                         spectral radius over the design grid    -
``<design>_multipliers``                 the best design's multipliers           -
``<design>_replay``                      the best design's open-loop replays     5-7
``<design>_filmstrip``                   the best design's cycle                 2 (from data)
``<design>_screen``                      candidates screened by survival         -
``<hardware_replay>_swings_train``       training swings: measured against the   -
                                         identified model's replay
``<hardware_replay>_swings_held_out``    held-out swings, likewise               -
``<hardware_replay>_residuals``          the replay's angle error over time      -
``<hardware_replay>_parameters``         identified parameters, 95 % intervals   -
``<hardware_replay>_held_out``           held-out errors of the three models     -
``<survival>_survival``                  survival fraction per cycle, per level  -
``<survival>_mfpt``                      mean first-passage time against noise   -
``<survival>_failure_modes``             how the runs ended, per level           -
``<survival>_height_drift``              height change of each completed run     -
``survival_mfpt_comparison``             every survival step's MFPT              -
``<atlas>_gaits``                        each gait's rho and MFPT against its    -
                                         rise per step (an atlas no route step
                                         plans with)
``<route>_wall``                         the wall and the planned route, steps   -
                                         coloured by gait
``<route>_walks``                        every walk of the route under noise,    -
                                         arrived and failed, failure points
``<route>_atlas``                        each gait's rho and MFPT against its    -
                                         rise per step
``<route>_outcomes``                     walks by how they ended; the arrived    -
                                         walks' time and energy
``<route>_animation``                    the plan walked without noise over the  -
                                         wall (MP4, or GIF)
=======================================  ======================================  ==============

The table lists every figure the step kinds declare (``tests/plotting/test_plotting_report.py``
holds it to them). Which figures a dataset gets is what its step kind declares
(:attr:`monkeystudy.study.steps.base.StepKind.figures`); how each is drawn is registered by the
kind's own plotting module, ``monkeystudy.plotting.kinds.<kind>`` (its ``DRAWINGS``), loaded for
every kind of the step registry (:data:`DRAWINGS`).
"""
from __future__ import annotations

import hashlib
import importlib
import json
import time
from contextlib import nullcontext
from dataclasses import dataclass
from pathlib import Path
from types import SimpleNamespace
from typing import Callable, Sequence

import xarray as xr

from ..study.failures import FAILED, StepFailure, read_failures
from ..study.figures import figure_name
from ..study.progress import count, ticking
from ..study.steps import REGISTRY
from . import gait
from .common import STYLE_FILE, atomic_path, provenance, save_figure
from .drawing import Drawing, Folder, NothingToDraw
from .page import PAGE, missing_steps, render_page, study_steps
from .workers import available_cores, run_jobs

MANIFEST = "manifest.json"
MANIFEST_VERSION = 1
FIGURES_DIR = "figures"

Progress = Callable[[str], None]


class ReportError(RuntimeError):
    """Some figures could not be drawn; ``written`` lists the files that were."""

    def __init__(self, failures: dict[str, str], written: list[Path]):
        self.failures = failures
        self.written = written
        lines = "\n".join(f"  {k}: {v.strip().splitlines()[-1]}" for k, v in failures.items())
        super().__init__(f"{count(len(failures), 'figure')} failed:\n{lines}")


class StudyIncomplete(RuntimeError):
    """Steps of the study have no current dataset; the figures of the others are drawn and the
    page lists every step (``written``: the files this report wrote).

    ``failed``: the steps whose last run failed or did not run them (a step they depend on
    failed), each with what became of it (their failure markers,
    :mod:`monkeystudy.study.failures`); ``missing``: steps without a dataset and without a
    marker (not run yet, or the run was interrupted)."""

    def __init__(self, failed: dict[str, str], missing: list[str], written: list[Path],
                 page: Path | None):
        self.failed = failed
        self.missing = missing
        self.written = written
        parts = []
        if failed:
            parts.append(f"{len(failed)} step{'s' if len(failed) != 1 else ''} failed or "
                         f"not run in the last run ({', '.join(failed)}): see why on the "
                         "page or in <step>.failed.json, correct the study and run it again")
        if missing:
            parts.append(f"{len(missing)} step{'s' if len(missing) != 1 else ''} without a "
                         f"dataset ({', '.join(missing)}): run the study to make "
                         f"{'it' if len(missing) == 1 else 'them'}")
        where = f"; page {page}" if page is not None else ""
        super().__init__(f"the study is incomplete: {'; '.join(parts)}{where}")


class ReportInterrupted(KeyboardInterrupt):
    """Ctrl-C during a report: the figures finished before it are saved (``written``) and in
    the manifest; no half-written file is left, and the same call again draws the rest."""

    def __init__(self, written: list[Path], left: int):
        self.written = written
        self.left = left
        super().__init__(f"interrupted: {count(len(written), 'file')} written, "
                         f"{count(left, 'figure')} left to draw; run the same command again "
                         "to finish")


@dataclass
class Job:
    """One figure (or animation) to draw from some datasets.

    The drawing is ``DRAWINGS[key]``; an ``across`` figure's inputs are the concatenated
    groups of ``sizes`` datasets each (one group per step)."""

    name: str                      # file name stem in figures/
    inputs: list[Path]             # dataset files it reads
    key: tuple[str, str]           # (step kind, figure suffix) in DRAWINGS
    title: str
    animation: bool = False
    sizes: tuple[int, ...] | None = None


@dataclass(frozen=True)
class Outcome:
    """What drawing a job came to: the files written, or why there was nothing to draw."""

    paths: tuple[Path, ...] = ()
    skipped: str | None = None
    seconds: float = 0.0


# ----------------------------------------------------------------------------------------------
def file_sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def code_hash() -> str:
    """Hash of the plotting package's source and the style file (a change redraws all)."""
    h = hashlib.sha256()
    package = Path(__file__).parent
    files = [(str(p.relative_to(package)), p) for p in sorted(package.rglob("*.py"))]
    for name, p in files + [(STYLE_FILE.name, STYLE_FILE)]:
        h.update(name.encode())
        h.update(p.read_bytes())
    return h.hexdigest()


#: how each declared figure is drawn, by (step kind, suffix), from every figure module
def kind_drawings(name: str) -> dict[tuple[str, str], Drawing]:
    """The drawings of step kind ``name``: its module ``monkeystudy.plotting.kinds.<name>``'s
    ``DRAWINGS`` (every kind the step registry holds has one)."""
    return importlib.import_module(f"{__package__}.kinds.{name}").DRAWINGS


DRAWINGS: dict[tuple[str, str], Drawing] = {
    key: how for name in REGISTRY for key, how in kind_drawings(name).items()}


def _kind(ds) -> str | None:
    """The step kind a dataset's figures are drawn for (None: no figures of ours). Datasets
    of unknown kinds are skipped; the layout is only guessed (grid, refine, stability) for
    files without a ``step_kind`` attribute."""
    kind = ds.attrs.get("step_kind")
    if kind is not None:
        return kind if kind in REGISTRY else None
    if "cycle" in ds.dims:
        return "stability"
    if "iteration" in ds.dims:
        return "refine"
    if "error" in ds and ({"dtheta1", "dtheta2"} <= set(ds.dims) or "point" in ds.dims):
        return "grid"
    return None


def _datasets(study_dir: Path) -> dict[str, list[Path]]:
    """Dataset files of the study folder by step kind (temporary and hidden files skipped)."""
    out: dict[str, list[Path]] = {k: [] for k in REGISTRY}
    for p in sorted(study_dir.glob("*.nc")):
        if p.name.startswith("."):
            continue
        try:
            with xr.open_dataset(p) as ds:
                kind = _kind(ds)
        except (OSError, ValueError):
            continue
        if kind:
            out[kind].append(p)
    return out


def load_dataset(path: Path) -> xr.Dataset:
    """A dataset file, read whole into memory (the file is closed again)."""
    with xr.open_dataset(path) as ds:
        return ds.load()


def plan(study_dir: Path, *, animation: bool = True, fps: float = 15.0,
         max_frames: int = 240) -> list[Job]:
    """The figures the datasets in ``study_dir`` support (nothing is drawn): for every step
    kind, in registry order, the figures it declares for each of its datasets. Raises
    :class:`FigureNameClash` when two of them would have the same file name."""
    study_dir = Path(study_dir)
    cache: dict[Path, xr.Dataset] = {}

    def loaded(path: Path) -> xr.Dataset:
        if path not in cache:
            cache[path] = load_dataset(path)
        return cache[path]

    folder = Folder(study_dir, _datasets(study_dir), loaded)
    jobs: list[Job] = []
    for kind in REGISTRY.values():
        paths = folder.files[kind.name]
        for fig in kind.figures:
            key = (kind.name, fig.suffix)
            how = DRAWINGS[key]
            if how.animation and not animation:
                continue
            if fig.across:
                groups = [[p] + how.extra_inputs(p, folder) for p in paths
                          if how.applies(p, folder)]
                if len(groups) > 1:
                    jobs.append(Job(figure_name(fig, "", kind.name), [p for g in groups for p in g],
                                    key, how.title, sizes=tuple(len(g) for g in groups)))
                continue
            for p in paths:
                if how.applies(p, folder):
                    jobs.append(Job(figure_name(fig, p.stem, kind.name),
                                    [p] + how.extra_inputs(p, folder), key,
                                    f"{p.stem}: {how.title}", animation=how.animation))
    clashes = name_clashes(jobs)
    if clashes:
        raise FigureNameClash(f"{study_dir}: " + "; ".join(clashes) + " (a figure is named "
                              "<step>_<figure>): rename one of the steps in the study and "
                              "run it again, or move a dataset that is not of this study "
                              "out of the folder")
    return jobs


class FigureNameClash(ValueError):
    """Two datasets of a folder would draw figures of the same file name (steps that a study
    file now refuses, or a dataset of another study in the folder): nothing is drawn."""


def name_clashes(jobs: Sequence[Job]) -> list[str]:
    """``figure X from a.nc (grid map) and b.nc (basin cycles_map)`` for each file name that
    two jobs would write."""
    first: dict[str, Job] = {}
    out = []

    def what(job: Job) -> str:
        kind, suffix = job.key
        if job.sizes is not None:
            return f"the {kind} datasets (their {kind} figure {suffix})"
        return f"{job.inputs[0].name} (its {kind} figure {suffix})"
    for job in jobs:
        other = first.setdefault(job.name, job)
        if other is not job:
            out.append(f"figure {job.name} would be drawn from {what(other)} and from "
                       f"{what(job)}")
    return out


def split_groups(datasets: list, sizes: Sequence[int]) -> list[list]:
    """``datasets`` cut into consecutive groups of ``sizes``."""
    out, k = [], 0
    for n in sizes:
        out.append(datasets[k:k + n])
        k += n
    return out


def draw_job(job: Job, fig_dir: Path, *, formats: Sequence[str], fps: float, max_frames: int,
             frames: Callable[[int, int], None] | None = None) -> Outcome:
    """Draw one job into ``fig_dir`` (its datasets read here: on a worker, by the worker).

    ``frames(done, total)`` follows an animation frame by frame. A drawing that raises
    :class:`~.drawing.NothingToDraw` comes back as a skipped :class:`Outcome`.
    """
    t0 = time.perf_counter()
    how = DRAWINGS[job.key]
    data = [load_dataset(p) for p in job.inputs]
    prov = provenance(data, job.inputs)
    base = fig_dir / job.name
    try:
        if job.animation:
            paths = how.draw(data, base, prov, fps=fps, max_frames=max_frames,
                             progress=frames)
        else:
            fig = how.draw(split_groups(data, job.sizes) if job.sizes else data)
            paths = save_figure(fig, base, prov, formats=formats, title=job.title)
            fig.clear()
    except NothingToDraw as why:
        return Outcome(skipped=why.reason, seconds=time.perf_counter() - t0)
    return Outcome(tuple(paths), seconds=time.perf_counter() - t0)


# ----------------------------------------------------------------------------------------------
def _read_manifest(path: Path) -> dict:
    try:
        m = json.loads(path.read_text())
        if m.get("version") == MANIFEST_VERSION and isinstance(m.get("figures"), dict):
            return m
    except (OSError, ValueError):
        pass
    return {"version": MANIFEST_VERSION, "figures": {}}


def _write_manifest(path: Path, manifest: dict) -> None:
    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(manifest, indent=1, sort_keys=True) + "\n")


def _prune(fig_dir: Path, manifest: dict, planned: set[str], study_dir: Path,
           progress: Progress | None) -> None:
    """Remove the figures (files and manifest entries) of datasets that no longer exist.

    Only files the manifest recorded are removed; figures merely not drawn this time (say,
    animations with ``animation=False``) are kept.
    """
    gone = [name for name, e in manifest["figures"].items()
            if name not in planned and not all((study_dir / i).exists() for i in e["inputs"])]
    for name in gone:
        for o in manifest["figures"][name].get("outputs", []):
            (fig_dir / o).unlink(missing_ok=True)
        del manifest["figures"][name]
        if progress:
            progress(f"removed {name}: its datasets are gone")
    if gone:
        _write_manifest(fig_dir / MANIFEST, manifest)


def _current(old: dict, entry: dict, fig_dir: Path) -> bool:
    """Whether a manifest entry still describes the figure: same inputs, code and options,
    and its files all there (or skipped, with nothing to show)."""
    if any(old.get(key) != entry[key] for key in entry):
        return False
    if "skipped" in old:
        return True
    return bool(old.get("outputs")) and all((fig_dir / o).exists() for o in old["outputs"])


class NoStudyDatasets(ValueError):
    """A folder without study datasets (``*.nc`` written by ``monkeystudy run``)."""


def study_datasets(study_dir: Path) -> list[Path]:
    """The study datasets in ``study_dir`` (``*.nc`` with a known ``step_kind``)."""
    return [p for paths in _datasets(Path(study_dir)).values() for p in paths]


def no_datasets_message(study_dir: Path) -> str:
    """Why ``study_dir`` cannot be reported, naming the study folders below it, if any."""
    below = sorted(p.parent for p in Path(study_dir).glob("*/*.nc")
                   if not p.name.startswith(".") and study_datasets(p.parent))
    below = sorted(set(below))
    msg = f"{study_dir} holds no study datasets (the *.nc files 'monkeystudy run' writes)"
    if below:
        msg += ("; the study folders below it are " + ", ".join(str(b) for b in below)
                + f": report one of them, e.g. 'monkeystudy report {below[0]}'")
    return msg


#: while figures are drawn, the longest time without a line [s]: then one says what is being
#: drawn, for how long (and an animation's frames)
STILL_DRAWING = 1.5


def _quarters(total: int) -> set[int]:
    """Frame counts at which an animation's progress is said: each quarter, and the end."""
    return {max(1, (total * q) // 4) for q in (1, 2, 3, 4)}


def report_study(study_dir: Path, *, force: bool = False,
                 formats: Sequence[str] = ("png", "pdf"), animation: bool = True,
                 fps: float = 15.0, max_frames: int = 240, dry_run: bool = False,
                 progress: Progress | None = None, workers: int | None = None) -> list[Path]:
    """Draw every figure the datasets in ``study_dir`` support into ``study_dir/figures``, and
    the study's page ``figures/index.html`` (:mod:`monkeystudy.plotting.page`).

    Parameters
    ----------
    study_dir : Path
        A study's output folder (``outputs/<study name>``) holding its ``*.nc`` datasets.
    force : bool
        Redraw every figure even when its inputs are unchanged.
    formats : sequence of str
        Still-figure formats (PNG and PDF by default; PNG is always drawn: the page shows it).
    animation : bool
        Also write each stability run's animation (MP4 with ffmpeg, else GIF).
    fps, max_frames : float, int
        Animation frame rate [s⁻¹] and frame budget (longer runs play faster than real time).
    dry_run : bool
        Draw nothing; return the files that would be written.
    progress : callable, optional
        Called with one line of text per figure (started, up to date, skipped with its
        reason, failed), with an animation's frames at each quarter, and a last line that
        sums up.
    workers : int, optional
        Processes drawing at once (default: one per available core).

    Returns
    -------
    list of Path
        The files written by this call (empty when everything was up to date); with
        ``dry_run``, the files that would be written.

    Every step of the study (as last run: its newest study text) is on the page; one without
    a current dataset is said to have failed, or not run, with the reason its failure marker
    gives (:mod:`monkeystudy.study.failures`), in the log too.

    Raises
    ------
    NoStudyDatasets
        ``study_dir`` holds no study dataset and no failure marker (the message names study
        folders below it).
    FigureNameClash
        Two datasets would draw figures of the same file name; nothing is drawn.
    ReportError
        When some figures failed; the others are written (and listed in ``.written``).
    StudyIncomplete
        When some steps of the study have no current dataset (after everything else is
        drawn and the page is written; not with ``dry_run``).
    ReportInterrupted
        On Ctrl-C (a ``KeyboardInterrupt``): what was finished is saved and in the manifest.
    """
    study_dir = Path(study_dir)
    if not study_dir.is_dir():
        raise FileNotFoundError(f"no study folder {study_dir}")
    formats = list(dict.fromkeys(["png"] + [f.lower() for f in formats]))
    # reading the datasets, hashing them and the plotting code takes seconds for a large
    # study: said while it lasts
    with ticking(progress, "planning the figures") if progress else nullcontext():
        jobs = plan(study_dir, animation=animation, fps=fps, max_frames=max_frames)
        hashes = {p: file_sha256(p) for job in jobs for p in job.inputs}
        code = code_hash()
    files = study_datasets(study_dir)
    step_failures = read_failures(study_dir)
    if not files and not step_failures:
        raise NoStudyDatasets(no_datasets_message(study_dir))
    # what became of every step of the study: its failure marker, or no dataset at all
    attrs = dataset_attrs(files)
    steps = list(study_steps(attrs, step_failures))
    incomplete = missing_steps(attrs, step_failures)
    for name, f in step_failures.items():
        if name not in incomplete:        # a dataset of an earlier run is there
            incomplete[name] = (f"{'failed' if f.state == FAILED else 'not run'}: {f.reason} "
                                "(its dataset is of an earlier run)")
    fig_dir = study_dir / FIGURES_DIR
    if not dry_run:
        fig_dir.mkdir(parents=True, exist_ok=True)
    manifest_path = fig_dir / MANIFEST
    manifest = _read_manifest(manifest_path)
    written: list[Path] = []
    failures: dict[str, str] = {}
    options = {"formats": formats, "fps": fps, "max_frames": max_frames}
    if animation and any(j.animation for j in jobs) and gait.ffmpeg_path() is None \
            and progress:
        progress("animations as GIF: no ffmpeg (install imageio-ffmpeg for MP4)")

    # figures are numbered in the order they are said: up to date first, then each drawn
    # one as it starts (the longest first, not the plan's order)
    numbers: dict[str, int] = {}
    last_line = [time.monotonic()]

    def line(text: str) -> None:
        last_line[0] = time.monotonic()
        if progress:
            progress(text)

    def say(k: int, job: Job, what: str) -> None:
        number = numbers.setdefault(job.name, len(numbers) + 1)
        line(f"[{number}/{len(jobs)}] {job.name}: {what}")

    todo: list[tuple[int, Job, dict]] = []
    for k, job in enumerate(jobs, 1):
        entry = {"inputs": {p.name: hashes[p] for p in job.inputs}, "code": code,
                 "options": options if job.animation else {"formats": formats}}
        if not force and _current(manifest["figures"].get(job.name, {}), entry, fig_dir):
            say(k, job, "up to date")
        elif dry_run:
            exts = ([gait.animation_format()] if job.animation else formats)
            written += [fig_dir / f"{job.name}.{e}" for e in exts]
            say(k, job, f"would draw ({job.title})")
        else:
            todo.append((k, job, entry))

    counts = {"drawn": 0, "skipped": 0}
    said: dict[int, set[int]] = {}
    drawing: dict[int, list] = {}          # job -> [started, frames done, frames]

    def run_one(i: int, send) -> Outcome:
        return draw_job(todo[i][1], fig_dir, formats=formats, fps=fps, max_frames=max_frames,
                        frames=lambda done, total: send((done, total)))

    def handle(i: int, event: str, value) -> None:
        k, job, entry = todo[i]
        if event == "start":
            drawing[i] = [time.monotonic(), 0, 0]
            say(k, job, f"drawing ({job.title})")
        elif event == "message":
            done, total = value
            if i in drawing:
                drawing[i][1:] = [done, total]
            marks = said.setdefault(i, _quarters(total))
            if done in marks:
                marks.discard(done)
                say(k, job, f"animation: {done}/{total} frames")
        elif event == "failed":
            drawing.pop(i, None)
            failures[job.name] = value
            say(k, job, f"failed: {value.strip().splitlines()[-1]}")
        else:
            drawing.pop(i, None)
            _record(job, entry, value)
            if value.skipped is not None:
                counts["skipped"] += 1
                say(k, job, f"skipped: {value.skipped}")
            else:
                counts["drawn"] += 1
                written.extend(value.paths)

    def _record(job: Job, entry: dict, outcome: Outcome) -> None:
        old = manifest["figures"].get(job.name, {})
        if outcome.skipped is not None:
            entry["outputs"] = []
            entry["skipped"] = outcome.skipped
            for o in old.get("outputs", []):       # a figure drawn before is no longer true
                (fig_dir / o).unlink(missing_ok=True)
        else:
            entry["outputs"] = [p.name for p in outcome.paths]
        manifest["figures"][job.name] = entry
        _write_manifest(manifest_path, manifest)

    def still_drawing() -> None:
        """A line when none came for :data:`STILL_DRAWING`: what is being drawn, how long."""
        now = time.monotonic()
        if not drawing or now - last_line[0] < STILL_DRAWING:
            return
        line("drawing " + ", ".join(
            f"{todo[i][1].name} ({now - t0:.0f} s"
            + (f", {done}/{total} frames" if total else "") + ")"
            for i, (t0, done, total) in sorted(drawing.items(), key=lambda x: x[1][0])))

    # longest first (the animations, then the many-panel figures): the processes then finish
    # close together; ties in the plan's order
    order = sorted(range(len(todo)), key=lambda i: -DRAWINGS[todo[i][1].key].cost)
    try:
        run_jobs(order, run_one, handle, workers or available_cores(), still_drawing)
    except KeyboardInterrupt:
        # a drawing process killed while writing leaves its temporary file (.<name>.*)
        for tmp in fig_dir.glob(".*"):
            if tmp.is_file():
                tmp.unlink(missing_ok=True)
        left = len(todo) - counts["drawn"] - counts["skipped"] - len(failures)
        raise ReportInterrupted(written, left) from None
    drawn, skipped = counts["drawn"], counts["skipped"]
    if not dry_run:
        _prune(fig_dir, manifest, {j.name for j in jobs}, study_dir, progress)
        page = _write_page(study_dir, files, manifest, step_failures)
        if page is not None:
            written.append(page)
    elif written or not (fig_dir / PAGE).exists():
        written.append(fig_dir / PAGE)
    if progress:
        if steps:
            states = {n: w.split(":")[0] for n, w in incomplete.items()}
            progress(f"{count(len(steps), 'step')} in the study: " + ", ".join(
                n + (f" ({states[n]})" if n in states else "") for n in steps))
        for name, what in incomplete.items():
            progress(f"step {name}: {what}")
        up = len(jobs) - len(todo)
        page_path = fig_dir / PAGE
        steps = (f"; {count(len(incomplete), 'step')} without a current dataset"
                 if incomplete else "")
        if dry_run:
            progress(f"{study_dir}: {count(len(written), 'file')} would be written{steps}")
        elif not written and not skipped:
            progress(f"{study_dir}: up to date ({count(len(jobs), 'figure')}, {page_path})"
                     f"{steps}")
        else:
            progress(f"{study_dir}: drew {count(drawn, 'figure')}, "
                     + (f"{skipped} skipped (nothing to show), " if skipped else "")
                     + f"{up} up to date"
                     + (f", {len(failures)} failed" if failures else "")
                     + f"; page {page_path}{steps}")
    if failures:
        raise ReportError(failures, written)
    if incomplete and not dry_run:
        raise StudyIncomplete({n: w for n, w in incomplete.items() if n in step_failures},
                              [n for n in incomplete if n not in step_failures], written,
                              fig_dir / PAGE)
    return written


def dataset_attrs(files: Sequence[Path]) -> dict[str, SimpleNamespace]:
    """The global attributes of each dataset by file stem (``.attrs``; nothing else read)."""
    out = {}
    for p in files:
        with xr.open_dataset(p) as ds:
            out[p.stem] = SimpleNamespace(attrs=dict(ds.attrs))
    return out


def _write_page(study_dir: Path, files: list[Path], manifest: dict,
                step_failures: dict[str, StepFailure]) -> Path | None:
    """Write ``figures/index.html`` if its content changed; return its path if written. The
    page shows every figure the manifest holds (those not drawn this time, e.g. animations
    with ``animation=False``, are still there), says why each skipped one has none, and what
    became of each step without a current dataset (``step_failures``: the run's markers)."""
    datasets = {p.stem: load_dataset(p) for p in files}
    figures = {name: e.get("outputs", []) for name, e in manifest["figures"].items()
               if "skipped" not in e}
    skipped = {name: e["skipped"] for name, e in manifest["figures"].items() if "skipped" in e}
    text = render_page(study_dir, datasets, figures, skipped, step_failures,
                       drawings=DRAWINGS)
    path = study_dir / FIGURES_DIR / PAGE
    if path.exists() and path.read_text() == text:
        return None
    with atomic_path(path) as tmp:
        tmp.write_text(text)
    return path
