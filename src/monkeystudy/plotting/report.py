"""Draw every figure a study folder's datasets support, redrawing only what changed.

``report_study(DIR)`` reads the study's ``*.nc`` datasets (docs/datasets.md; classified by
their ``step_kind`` attribute), plans the figures they support and writes each as PNG and PDF
(the animation as GIF, and MP4 when ffmpeg exists) into ``DIR/figures/``. It never simulates.

A manifest, ``DIR/figures/manifest.json``, records per figure the SHA-256 of each input
dataset, a hash of the plotting code and style file, and the drawing options. A figure is
redrawn only when one of those changed or one of its files is missing, so a second call on
unchanged datasets writes nothing. Figures whose datasets were deleted are removed.

=====================================  ======================================  ==============
file (``figures/``)                    what                                    study figure
=====================================  ======================================  ==============
``<grid>_surface``                     sqrt(error) surface, no-gait floor      3
``<grid>_map``                         error map truncated at 5, minima        4, 9, 10
``<refine>_convergence``               best-vertex error per iteration         (text 4.2)
``<stability>_error``                  error per cycle, log scale              5, 8
``<stability>_kinetic_energy``         kinetic energy per cycle                6
``<stability>_height``                 attached-end height per cycle           7
``<stability>_filmstrip``              one gait cycle, frame by frame          2 (from data)
``<stability>_animation``              the whole run (GIF / MP4)               -
``stability_error_comparison``         all multi-cycle runs' errors            5 + 8
``<shoot>_newton``                     residual norm per Newton iteration      -
``<floquet>_multipliers``              multipliers and the unit circle         -
``<tick_sweep>_error_growth``          error per cycle per tick, |lambda|^2n   -
``<basin>_cycles_map``                 cycles to failure around the gait       -
``<continuation>_branch``              gait family, |lambda| along it          -
``<work_precision>_work_precision``    wall time per gait against error        -
``<stress>_stress``                    energy drift, long runs, extreme cases  -
``<design>_map``                       spectral radius over the design grid    -
``<design>_multipliers``               the best design's multipliers           -
``<design>_replay``                    the best design's open-loop replays     5-7
``<design>_filmstrip``                 the best design's cycle                 2 (from data)
=====================================  ======================================  ==============

Which figures a dataset gets is what its step kind declares
(:attr:`monkeystudy.study.steps.base.StepKind.figures`); how each is drawn is registered by the
figure modules (their ``DRAWINGS``, merged in :data:`DRAWINGS`).
"""
from __future__ import annotations

import hashlib
import json
import traceback
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Sequence

import xarray as xr

from ..study.steps import REGISTRY
from . import analysis, cycles, design, gait, maps, stress, survival
from .common import STYLE_FILE, atomic_path, provenance, save_figure
from .drawing import Drawing, Folder
from .page import PAGE, render_page

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
        super().__init__(f"{len(failures)} figure(s) failed:\n{lines}")


@dataclass
class Job:
    """One figure (or animation) to draw from some datasets."""

    name: str                      # file name stem in figures/
    inputs: list[Path]             # dataset files it reads
    draw: Callable                 # (loaded datasets in ``inputs`` order) -> Figure
    title: str
    animation: bool = False
    outputs: list[str] = field(default_factory=list)   # filled once drawn


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
    files = sorted(Path(__file__).parent.glob("*.py")) + [STYLE_FILE]
    for p in files:
        h.update(p.name.encode())
        h.update(p.read_bytes())
    return h.hexdigest()


#: how each declared figure is drawn, by (step kind, suffix), from every figure module
DRAWINGS: dict[tuple[str, str], Drawing] = {
    **maps.DRAWINGS, **cycles.DRAWINGS, **gait.DRAWINGS, **analysis.DRAWINGS, **stress.DRAWINGS,
    **survival.DRAWINGS, **design.DRAWINGS,
}


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


def _load(path: Path) -> xr.Dataset:
    with xr.open_dataset(path) as ds:
        return ds.load()


def plan(study_dir: Path, *, animation: bool = True, fps: float = 15.0,
         max_frames: int = 240) -> list[Job]:
    """The figures the datasets in ``study_dir`` support (nothing is drawn): for every step
    kind, in registry order, the figures it declares for each of its datasets."""
    study_dir = Path(study_dir)
    cache: dict[Path, xr.Dataset] = {}

    def loaded(path: Path) -> xr.Dataset:
        if path not in cache:
            cache[path] = _load(path)
        return cache[path]

    folder = Folder(study_dir, _datasets(study_dir), loaded)
    jobs: list[Job] = []
    for kind in REGISTRY.values():
        paths = folder.files[kind.name]
        for fig in kind.figures:
            how = DRAWINGS[(kind.name, fig.suffix)]
            if how.animation and not animation:
                continue
            if fig.across:
                groups = [[p] + how.extra_inputs(p, folder) for p in paths
                          if how.applies(p, folder)]
                if len(groups) > 1:
                    sizes = [len(g) for g in groups]
                    jobs.append(Job(f"{kind.name}_{fig.suffix}", [p for g in groups for p in g],
                                    lambda d, how=how, sizes=sizes: how.draw(_split(d, sizes)),
                                    fig.title))
                continue
            for p in paths:
                if not how.applies(p, folder):
                    continue
                if how.animation:
                    def draw(d, base, prov, how=how):
                        return how.draw(d, base, prov, fps=fps, max_frames=max_frames)
                else:
                    draw = how.draw
                jobs.append(Job(f"{p.stem}_{fig.suffix}", [p] + how.extra_inputs(p, folder),
                                draw, f"{p.stem}: {fig.title}", animation=how.animation))
    return jobs


def _split(datasets: list, sizes: list[int]) -> list[list]:
    """``datasets`` cut into consecutive groups of ``sizes``."""
    out, k = [], 0
    for n in sizes:
        out.append(datasets[k:k + n])
        k += n
    return out


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


def report_study(study_dir: Path, *, force: bool = False,
                 formats: Sequence[str] = ("png", "pdf"), animation: bool = True,
                 fps: float = 15.0, max_frames: int = 240, dry_run: bool = False,
                 progress: Progress | None = None) -> list[Path]:
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
        Animation frame rate and frame budget (longer runs play faster than real time).
    dry_run : bool
        Draw nothing; return the files that would be written.
    progress : callable, optional
        Called with one line of text per figure (drawn or up to date) and a last line that
        sums up.

    Returns
    -------
    list of Path
        The files written by this call (empty when everything was up to date); with
        ``dry_run``, the files that would be written.

    Raises
    ------
    NoStudyDatasets
        ``study_dir`` holds no study dataset (the message names study folders below it).
    ReportError
        When some figures failed; the others are written (and listed in ``.written``).
    """
    study_dir = Path(study_dir)
    if not study_dir.is_dir():
        raise FileNotFoundError(f"no study folder {study_dir}")
    formats = list(dict.fromkeys(["png"] + [f.lower() for f in formats]))
    jobs = plan(study_dir, animation=animation, fps=fps, max_frames=max_frames)
    files = study_datasets(study_dir)
    if not files:
        raise NoStudyDatasets(no_datasets_message(study_dir))
    fig_dir = study_dir / FIGURES_DIR
    if not dry_run:
        fig_dir.mkdir(parents=True, exist_ok=True)
    manifest_path = fig_dir / MANIFEST
    manifest = _read_manifest(manifest_path)
    code = code_hash()
    hashes: dict[Path, str] = {}
    loaded: dict[Path, xr.Dataset] = {}
    written: list[Path] = []
    failures: dict[str, str] = {}
    options = {"formats": formats, "fps": fps, "max_frames": max_frames}
    if animation and any(j.animation for j in jobs) and gait.ffmpeg_path() is None \
            and progress:
        progress("animations as GIF: no ffmpeg (install imageio-ffmpeg for MP4)")
    drawn = 0

    def say(k: int, job: Job, what: str) -> None:
        if progress:
            progress(f"[{k}/{len(jobs)}] {job.name}: {what}")

    for k, job in enumerate(jobs, 1):
        for p in job.inputs:
            if p not in hashes:
                hashes[p] = file_sha256(p)
        entry = {"inputs": {p.name: hashes[p] for p in job.inputs}, "code": code,
                 "options": options if job.animation else {"formats": formats}}
        old = manifest["figures"].get(job.name, {})
        outputs_ok = bool(old.get("outputs")) and all((fig_dir / o).exists()
                                                      for o in old["outputs"])
        if not force and outputs_ok and all(old.get(key) == entry[key] for key in entry):
            say(k, job, "up to date")
            continue
        if dry_run:
            exts = ([gait.animation_format()] if job.animation else formats)
            written += [fig_dir / f"{job.name}.{e}" for e in exts]
            say(k, job, f"would draw ({job.title})")
            continue
        say(k, job, f"drawing ({job.title})")
        try:
            for p in job.inputs:
                if p not in loaded:
                    loaded[p] = _load(p)
            data = [loaded[p] for p in job.inputs]
            prov = provenance(data, job.inputs)
            base = fig_dir / job.name
            if job.animation:
                paths = job.draw(data, base, prov)
            else:
                fig = job.draw(data)
                paths = save_figure(fig, base, prov, formats=formats, title=job.title)
                fig.clear()
        except Exception:  # one broken figure must not stop the others
            failures[job.name] = traceback.format_exc()
            if progress:
                progress(f"    failed: {failures[job.name].strip().splitlines()[-1]}")
            continue
        drawn += 1
        written += paths
        entry["outputs"] = [p.name for p in paths]
        manifest["figures"][job.name] = entry
        _write_manifest(manifest_path, manifest)
    if not dry_run:
        _prune(fig_dir, manifest, {j.name for j in jobs}, study_dir, progress)
        page = _write_page(study_dir, files, manifest, loaded)
        if page is not None:
            written.append(page)
    elif written or not (fig_dir / PAGE).exists():
        written.append(fig_dir / PAGE)
    if progress:
        up = len(jobs) - drawn - len(failures) if not dry_run else 0
        page_path = fig_dir / PAGE
        if dry_run:
            progress(f"{study_dir}: {len(written)} file(s) would be written")
        elif not written:
            progress(f"{study_dir}: up to date ({len(jobs)} figures, {page_path})")
        else:
            progress(f"{study_dir}: drew {drawn} figure(s), {up} up to date"
                     + (f", {len(failures)} failed" if failures else "")
                     + f"; page {page_path}")
    if failures:
        raise ReportError(failures, written)
    return written


def _write_page(study_dir: Path, files: list[Path], manifest: dict,
                loaded: dict[Path, xr.Dataset]) -> Path | None:
    """Write ``figures/index.html`` if its content changed; return its path if written. The
    page shows every figure the manifest holds (those not drawn this time, e.g. animations
    with ``animation=False``, are still there)."""
    datasets = {p.stem: loaded[p] if p in loaded else _load(p) for p in files}
    figures = {name: e.get("outputs", []) for name, e in manifest["figures"].items()}
    text = render_page(study_dir, datasets, figures)
    path = study_dir / FIGURES_DIR / PAGE
    if path.exists() and path.read_text() == text:
        return None
    with atomic_path(path) as tmp:
        tmp.write_text(text)
    return path
