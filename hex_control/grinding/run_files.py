"""A demo run's files and options, on disk (no ROS): the options it was started with
(``run.json``, taken up by ``hexctl demo --resume``), the folder of its sequence planner's
job logs, the plant's workpiece file, and the folder of its recording."""

from __future__ import annotations

import json
import re
from pathlib import Path

from hex_control.grinding.job import unfinished_logs


def validated_namespace(namespace: str) -> str:
    """``namespace`` as ROS writes it (``/cell1``, or '' for the root); ValueError if it is not one."""
    namespace = namespace.rstrip("/")
    if namespace and not re.fullmatch(r"(/[A-Za-z][A-Za-z0-9_]*)+", namespace):
        raise ValueError(f"{namespace!r} is not a namespace: /name[/name...], letters, digits and _")
    return namespace


def fresh_recording_dir(output: Path) -> Path:
    """``output/recording``, an earlier run's moved aside to ``recording-<n>``."""
    directory = output / "recording"
    if directory.exists():
        n = 1
        while (output / f"recording-{n}").exists():
            n += 1
        directory.rename(output / f"recording-{n}")
    return directory


#: in the job directory: the part as the plant last scanned it (:mod:`hex_control.plant.workpiece_store`)
WORKPIECE_FILE = "workpiece.json"


def resumable_job_dir(output: Path) -> Path:
    """``output/jobs`` of a run that was cut off; ValueError if it holds no unfinished job."""
    jobs = Path(output) / "jobs"
    if not (jobs.is_dir() and unfinished_logs(jobs)):
        raise ValueError(f"{jobs} holds no unfinished job to resume")
    return jobs


def fresh_job_dir(output: Path) -> Path:
    """``output/jobs`` for this run's sequence planner, which resumes any unfinished job it
    finds there: an earlier run's that was cut off is moved aside to ``jobs-<n>`` first (a
    fresh demo must not take up an old job; the drills resume within one run)."""
    jobs = Path(output) / "jobs"
    if jobs.is_dir() and unfinished_logs(jobs):
        n = 1
        while (aside := jobs.with_name(f"jobs-{n}")).exists():
            n += 1
        jobs.rename(aside)
    return jobs


#: in a demo run's directory: the options it was started with, taken up by ``--resume``
RUN_FILE = "run.json"
#: ``hexctl demo``'s options that make a run what it is (its command-line names) and their defaults
RUN_DEFAULTS = {"seed": 0, "deadline": 100.0, "realtime": False, "real_time_factor": 1.0, "bead_length": 300.0,
                "bead_height": 1.0, "dulling": 0.0, "machine": "hexapod", "namespace": ""}


def _normalized(options: dict) -> dict:
    """Each option as its default's type (60 and 60.0 are one deadline; a namespace as ROS writes it)."""
    out = {name: type(RUN_DEFAULTS[name])(value) for name, value in options.items()}
    if "namespace" in out:
        out["namespace"] = validated_namespace(out["namespace"])
    return out


def run_options(given: dict, resume_dir: str | Path | None = None) -> dict:
    """The options of a demo run (RUN_DEFAULTS' keys): ``given`` (those on the command line,
    only the ones given) over the defaults; resuming the run in ``resume_dir``, the options it
    stored when it started (RUN_FILE). ValueError if a given option differs from the stored
    one, or if nothing is stored and no --seed is given (a run from before the options were
    kept: its seed is unknown)."""
    unknown = set(given) - set(RUN_DEFAULTS)
    if unknown:
        raise ValueError(f"not run options: {', '.join(sorted(unknown))}")
    given = _normalized(given)
    if resume_dir is None:
        return {**RUN_DEFAULTS, **given}
    path = Path(resume_dir) / RUN_FILE
    if not path.exists():
        if "seed" not in given:
            raise ValueError(f"{path} is missing (a run started before its options were kept): give the run's "
                             "--seed and other options to resume it")
        return {**RUN_DEFAULTS, **given}
    stored = _normalized({name: value for name, value in json.loads(path.read_text()).items() if name in RUN_DEFAULTS})
    conflicts = [f"--{name.replace('_', '-')} {value!r} (the run's: {stored[name]!r})" for name, value in given.items()
                 if name in stored and value != stored[name]]
    if conflicts:
        raise ValueError(f"--resume {resume_dir} keeps the options the run started with ({path}); these differ: "
                         f"{'; '.join(conflicts)}. Leave them out or give the run's")
    return {**RUN_DEFAULTS, **given, **stored}


def store_run_options(directory: Path, options: dict) -> Path:
    """``directory/RUN_FILE`` with the run's ``options`` (RUN_DEFAULTS' keys), for ``--resume``."""
    directory.mkdir(parents=True, exist_ok=True)
    path = directory / RUN_FILE
    path.write_text(json.dumps({name: options[name] for name in RUN_DEFAULTS}, indent=2) + "\n")
    return path
