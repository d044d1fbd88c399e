#!/usr/bin/env python3
"""Build everything: studies -> datasets -> figures, redoing only what is out of date.

    python pipeline/build.py                      # every studies/*.yaml into outputs/
    python pipeline/build.py --studies studies/horizontal.yaml --out outputs
    python pipeline/build.py --dry-run            # say what would run and what would be drawn

For each study file:

1. **datasets** - the study runner's own plan (``monkeystudy.study.plan.plan_study``) says
   whether ``<out>/<study name>/<step>.nc`` exist and are current: same step key
   (``step_sha256``: the robot, gait, integrator, the step's settings and its dependencies'
   keys - editing one step reruns only it and what depends on it) and same simulation code
   (``code_sha256``, a hash of the simulation and study packages and the dataset layout - an
   edit to the figure code does not rerun studies).
   Missing or stale steps are run with ``monkeystudy run STUDY --out DIR`` in a subprocess
   (its progress is shown; it resumes from saved shards and skips current steps itself).
2. **figures** - ``monkeystudy.plotting.report.report_study`` redraws only the figures whose
   input datasets (SHA-256), drawing options or plotting code changed, into
   ``<out>/<study name>/figures/``.

Exit status: 0 when every study and figure is done, 1 when something failed (the rest is still
built), 2 for bad arguments.
"""
from __future__ import annotations

import argparse
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def log(msg: str) -> None:
    print(msg, flush=True)


def study_files(args_studies: list[str] | None) -> list[Path]:
    if args_studies:
        files = [Path(s) for s in args_studies]
    else:
        files = sorted((REPO / "studies").glob("*.yaml"))
    missing = [f for f in files if not f.is_file()]
    if missing:
        raise SystemExit(f"build.py: no such study file: {', '.join(map(str, missing))}")
    return files


def datasets_step(study: Path, out: Path, *, workers: int | None, dry_run: bool):
    """Bring the study's datasets up to date. Returns (study name, study dir, state, ok)."""
    from monkeystudy.study.loader import StudyError, load_study
    from monkeystudy.study.plan import plan_study
    from monkeystudy.study.progress import all_of, count

    try:
        loaded = load_study(study)
    except StudyError as exc:
        log(f"  invalid study file:\n{exc}")
        return None, None, "invalid", False
    name = loaded.study.name
    study_dir = out / name
    plan = plan_study(loaded, study_dir)
    todo = [s.name for s in plan.steps if not s.up_to_date]
    if not todo:
        log(f"  datasets: {all_of(len(plan.steps), 'dataset')} up to date in {study_dir}")
        return name, study_dir, "up to date", True
    log(f"  datasets: {len(todo)} of {len(plan.steps)} missing or stale ({', '.join(todo)})")
    if dry_run:
        for line in plan.describe().splitlines():
            log(f"    {line}")
        return name, study_dir, "would run", True
    cmd = [sys.executable, "-m", "monkeystudy.cli", "run", str(study), "--out", str(study_dir)]
    if workers:
        cmd += ["--workers", str(workers)]
    log(f"  running: {' '.join(cmd[2:])}")
    t0 = time.monotonic()
    rc = subprocess.call(cmd, cwd=REPO)          # inherits the terminal: the runner's progress
    dt = time.monotonic() - t0
    if rc != 0:
        log(f"  datasets: the run failed (exit {rc}) after {dt:.1f} s")
        return name, study_dir, f"run failed (exit {rc})", False
    log(f"  datasets: done in {dt:.1f} s")
    return name, study_dir, f"ran {count(len(todo), 'step')} in {dt:.0f} s", True


def figures_step(study_dir: Path, *, force: bool, animation: bool, dry_run: bool,
                 formats: list[str]):
    """Redraw the figures whose inputs changed. Returns (state, ok)."""
    from monkeystudy.plotting.report import (
        FigureNameClash, ReportError, StudyIncomplete, report_study, study_datasets,
    )
    from monkeystudy.study.progress import count

    if not study_dir.is_dir() or not study_datasets(study_dir):
        log("  figures: no datasets yet")
        return "no datasets yet", dry_run

    def progress(line: str) -> None:
        log(f"    {line}")

    log(f"  figures -> {study_dir / 'figures'}")
    t0 = time.monotonic()
    try:
        written = report_study(study_dir, force=force, animation=animation, dry_run=dry_run,
                               formats=formats, progress=progress)
    except ReportError as exc:
        log(f"  figures: {exc}")
        return f"{len(exc.failures)} failed, {count(len(exc.written), 'file')} written", False
    except FigureNameClash as exc:
        log(f"  figures: {exc}")
        return "refused: figure names clash", False
    except StudyIncomplete as exc:    # the rest is drawn; the page lists the missing steps
        log(f"  figures: {exc}")
        n = len(exc.failed) + len(exc.missing)
        return f"wrote {count(len(exc.written), 'file')}; {count(n, 'step')} without a dataset", \
            False
    verb = "would write" if dry_run else "wrote"
    return f"{verb} {count(len(written), 'file')} in {time.monotonic() - t0:.0f} s", True


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="pipeline/build.py",
        description="Studies -> datasets -> figures, redoing only what is out of date.")
    ap.add_argument("--studies", nargs="+", metavar="STUDY.yaml",
                    help="study files (default: every studies/*.yaml)")
    ap.add_argument("--out", type=Path, default=REPO / "outputs",
                    help="output root; each study goes to OUT/<study name> (default: outputs)")
    ap.add_argument("--workers", "-j", type=int, default=None,
                    help="local worker processes for the study runs (default: all cores)")
    # the figure options are 'monkeystudy report's own
    ap.add_argument("--force", action="store_true",
                    help="redraw every figure even if its inputs are unchanged")
    ap.add_argument("--no-animation", action="store_true", help="skip the animations")
    ap.add_argument("--formats", default="png,pdf", metavar="LIST",
                    help="still-figure formats, comma-separated (default: png,pdf)")
    ap.add_argument("--dry-run", action="store_true",
                    help="say what would run and what would be drawn; change nothing")
    args = ap.parse_args(argv)

    files = study_files(args.studies)
    out = args.out.resolve()
    summary, all_ok = [], True
    t_start = time.monotonic()
    for k, study in enumerate(files, 1):
        log(f"[{k}/{len(files)}] {study}")
        name, study_dir, ds_state, ok = datasets_step(study, out, workers=args.workers,
                                                      dry_run=args.dry_run)
        all_ok &= ok
        fig_state = "-"
        if study_dir is not None:
            fig_state, fok = figures_step(study_dir, force=args.force,
                                          animation=not args.no_animation,
                                          dry_run=args.dry_run,
                                          formats=[f for f in args.formats.split(",") if f])
            all_ok &= fok
        summary.append((name or study.stem, ds_state, fig_state))

    log(f"\nsummary ({time.monotonic() - t_start:.0f} s, outputs in {out}):")
    width = max(len(s[0]) for s in summary)
    for name, ds_state, fig_state in summary:
        log(f"  {name:<{width}}  datasets: {ds_state};  figures: {fig_state}")
    return 0 if all_ok else 1


if __name__ == "__main__":
    sys.exit(main())
