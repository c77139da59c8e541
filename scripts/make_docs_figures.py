"""Regenerate every image the documentation shows, so that none is stale.

    python scripts/make_docs_figures.py                 # every figure (about 40 minutes on 2 cores)
    python scripts/make_docs_figures.py --skip-slow     # all but the ones over 3 minutes
    python scripts/make_docs_figures.py course_robot_maps maps_particles ...   # these only
    python scripts/make_docs_figures.py --list          # the table below
    python scripts/make_docs_figures.py --check         # every image docs/*.md, README.md and
                                                        # experiments/ show is made by an entry
    make figures                                        # the first line

``FIGURES`` is the list: one line per figure (or group of figures made together): its name, the
files it writes (globs, relative to the repository), the commands that make them and about how many
minutes they take. Commands run in the repository root, one after the other; ``mazeslam`` and
``python`` are this interpreter's; ``{tmp}`` is a scratch folder, ``{log1}``, ``{carmen}`` the shared
data; ``copy A B`` copies a file. A new figure is one new line. Images of experiment sweeps come from
``mazeslam report`` over the committed results.csv; their maps.png needs the per-run maps
(``results/maps/``, not committed), which only the sweep itself writes: without them the report
leaves maps.png as it is and this script says so.
"""

from __future__ import annotations

import argparse
import glob
import re
import shlex
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data"
PLACES = {"log1": str(DATA / "course" / "log1.txt"), "carmen": str(DATA / "carmen"), "mrclam": str(DATA / "mrclam")}

SLOW_MINUTES = 3.0

#: (name, files written (space-separated globs), commands ("; " between them), about how many minutes)
# fmt: off
FIGURES: list[tuple[str, str, str, float]] = [
    ("corners_simulated", "docs/img/corners_simulated.png", "mazeslam simulate --seed 0 --out {tmp}/doc.log --quiet; mazeslam corners {tmp}/doc.log --scan 60 --plot docs/img/corners_simulated.png", 0.3),  # noqa: E501
    ("corners_csail", "docs/img/corners_csail.png", "mazeslam corners {carmen}/csail-corrected.log.gz --config configs/carmen.toml --scan 254 --plot docs/img/corners_csail.png", 0.2),  # noqa: E501
    ("corners_freiburg079", "docs/img/corners_freiburg079.png", "mazeslam corners {carmen}/freiburg-079-corrected.log.gz --config configs/carmen.toml --scan 2926 --plot docs/img/corners_freiburg079.png", 0.3),  # noqa: E501
    ("fastslam_default_maze", "docs/img/fastslam_default_maze.png experiments/fastslam_default_maze/results.csv experiments/fastslam_default_maze/results.md", "python -m experiments.fastslam_default_maze.run", 2.0),  # noqa: E501
    ("mrclam", "docs/img/mrclam_robot1_unknown.png docs/img/mrclam_robot1_nees.png experiments/mrclam/results.md", "python -m experiments.mrclam.run", 2.0),  # noqa: E501
    ("maze_env", "docs/img/maze_env.png", "python scripts/figures/maze_env.py", 0.3),
    ("vector_env_coverage", "docs/img/vector_env_coverage.png", "python examples/train_vector_explorer.py --figure docs/img/vector_env_coverage.png", 5.0),  # noqa: E501
    ("carmen", "docs/img/carmen/*.png experiments/carmen/results/table.md", "python -m experiments.carmen.run", 15.0),  # noqa: E501
    ("posegraph_aces", "docs/img/posegraph_aces.png", "mazeslam import carmen {carmen}/aces-corrected.log.gz --out {tmp}/aces.log; mazeslam smooth {tmp}/aces.log --out {tmp}/smooth; copy {tmp}/smooth/smooth.png docs/img/posegraph_aces.png", 1.0),  # noqa: E501
    # experiments/
    ("smooth_404", "experiments/smoother/smooth_404.png", "mazeslam simulate --seed 404 --out {tmp}/s404.log --quiet; mazeslam smooth {tmp}/s404.log --out {tmp}/smooth; copy {tmp}/smooth/smooth.png experiments/smoother/smooth_404.png", 0.5),  # noqa: E501
    ("blind_cloud", "experiments/blind_cloud/results/*/*.png experiments/blind_cloud/results/*/*.json experiments/blind_cloud/results/*/*.csv", "python -m experiments.blind_cloud.run", 0.5),  # noqa: E501
    ("consistency", "experiments/consistency/nees_over_time.png experiments/consistency/results.csv experiments/consistency/summary.md", "python -m experiments.consistency.run", 20.0),  # noqa: E501
    ("consistency_held_out", "experiments/consistency/held_out/nees_over_time.png experiments/consistency/held_out/results.csv experiments/consistency/held_out/summary.md", "python -m experiments.consistency.run --seeds 21 22 23 24 25 26 27 28 29 30 31 32 33 34 35 36 37 38 39 40 --particles 100 1000 --versions 2 --out experiments/consistency/held_out", 15.0),  # noqa: E501
    ("carmen_grid", "experiments/carmen_grid/results/*_compare.png", "python -m experiments.carmen_grid.figures", 0.2),  # noqa: E501
    ("course_robot_sensor", "experiments/course_robot/sensor_comparison.png", "python -m experiments.course_robot.sensor_comparison", 1.0),  # noqa: E501
    ("course_robot_maps", "docs/img/course_log1_maps.png docs/img/course_sim_maps.png", "python -m experiments.course_robot.figures", 3.0),  # noqa: E501
    ("maps_particles", "experiments/particles/results/*.png", "mazeslam report experiments/particles/results", 0.1),  # noqa: E501
    ("maps_odometry_variance", "experiments/odometry_variance/results/*.png", "mazeslam report experiments/odometry_variance/results", 0.1),  # noqa: E501
    ("maps_sensor_variance", "experiments/sensor_variance/results/*.png", "mazeslam report experiments/sensor_variance/results", 0.1),  # noqa: E501
    ("maps_sensor_variance_scale", "experiments/sensor_variance/results_scale/*.png", "mazeslam report experiments/sensor_variance/results_scale", 0.1),  # noqa: E501
    ("maps_scan_points", "experiments/scan_points/results/*.png", "mazeslam report experiments/scan_points/results", 0.1),  # noqa: E501
    ("maps_fastslam_version", "experiments/fastslam_version/results/*.png", "mazeslam report experiments/fastslam_version/results", 0.1),  # noqa: E501
    ("maps_landmarks", "experiments/landmarks/results/*.png", "mazeslam report experiments/landmarks/results", 0.1),  # noqa: E501
    ("maps_failure_default", "experiments/failure_cases/default/results/*.png", "mazeslam report experiments/failure_cases/default/results", 0.1),  # noqa: E501
    ("maps_failure_few_points", "experiments/failure_cases/few_points/results/*.png", "mazeslam report experiments/failure_cases/few_points/results", 0.1),  # noqa: E501
    ("maps_failure_long_corridor", "experiments/failure_cases/long_corridor/results/*.png", "mazeslam report experiments/failure_cases/long_corridor/results", 0.1),  # noqa: E501
    ("maps_failure_narrow", "experiments/failure_cases/narrow/results/*.png", "mazeslam report experiments/failure_cases/narrow/results", 0.1),  # noqa: E501
    ("maps_failure_sparse_turns", "experiments/failure_cases/sparse_turns/results/*.png", "mazeslam report experiments/failure_cases/sparse_turns/results", 0.1),  # noqa: E501
    ("maps_failure_symmetric", "experiments/failure_cases/symmetric/results/*.png", "mazeslam report experiments/failure_cases/symmetric/results", 0.1),  # noqa: E501
    ("maps_failure_wide_room", "experiments/failure_cases/wide_room/results/*.png", "mazeslam report experiments/failure_cases/wide_room/results", 0.1),  # noqa: E501
]
# fmt: on

#: Where the documentation shows images from: markdown files (globs, relative to the repository).
DOCUMENTS = ["README.md", "docs/*.md", "experiments/*.md", "experiments/**/*.md"]
IMAGE = re.compile(r"\]\(<?([^)>\s]+\.(?:png|gif|jpg|jpeg|svg))>?\)")


def commands_of(commands: str, tmp: Path) -> list[list[str]]:
    """The entry's commands as argument lists, with the placeholders filled in."""
    places = {**PLACES, "tmp": str(tmp)}
    runs = []
    for command in commands.split("; "):
        words = shlex.split(command.format(**places))
        if words[0] == "mazeslam":
            words = [sys.executable, "-m", "mazeslam.cli", *words[1:]]
        elif words[0] == "python":
            words = [sys.executable, *words[1:]]
        runs.append(words)
    return runs


def outputs_of(pattern: str, root: Path = ROOT) -> list[Path]:
    """The files an entry's globs match now."""
    return sorted({Path(p) for part in pattern.split() for p in glob.glob(str(root / part))})


def make(name: str, outputs: str, commands: str, root: Path = ROOT) -> list[str]:
    """Run one entry; return its problems (a command failed, an output missing, empty or not rewritten)."""
    began = time.time()
    with tempfile.TemporaryDirectory() as tmp:
        for words in commands_of(commands, Path(tmp)):
            if words[0] == "copy":
                shutil.copyfile(words[1], root / words[2])
                continue
            done = subprocess.run(words, cwd=root, capture_output=True, text=True)
            if done.returncode != 0:
                return [f"{name}: {shlex.join(words)} failed:\n{done.stderr[-2000:]}"]
    problems = []
    written = outputs_of(outputs, root)
    if not written:
        problems.append(f"{name}: nothing matches {outputs}")
    for path in written:
        if path.stat().st_size == 0:
            problems.append(f"{name}: {path.relative_to(root)} is empty")
        elif path.stat().st_mtime < began and path.suffix == ".png":
            problems.append(
                f"{name}: {path.relative_to(root)} was not rewritten"
                + (" (maps.png needs the sweep's results/maps/: rerun the sweep)" if path.name == "maps.png" else "")
            )
    return problems


#: Folders whose committed images count as shown even where no markdown links them.
IMAGE_FOLDERS = ["docs/img", "experiments"]


def committed_images(root: Path = ROOT) -> set[Path]:
    """The images git holds in ``IMAGE_FOLDERS`` (none outside a git checkout)."""
    listed = subprocess.run(
        ["git", "ls-files", "--", *[f"{folder}/*.{kind}" for folder in IMAGE_FOLDERS for kind in ("png", "gif")]],
        cwd=root,
        capture_output=True,
        text=True,
    )
    return {(root / line).resolve() for line in listed.stdout.splitlines()} if listed.returncode == 0 else set()


def shown_images(root: Path = ROOT) -> list[Path]:
    """Every image file the documentation links to that the repository holds, and every committed
    image in docs/img/ and experiments/."""
    images = committed_images(root)
    for pattern in DOCUMENTS:
        for document in glob.glob(str(root / pattern), recursive=True):
            for link in IMAGE.findall(Path(document).read_text()):
                path = (Path(document).parent / link).resolve()
                if path.is_file() and root in path.parents:
                    images.add(path)
    return sorted(images)


def uncovered(root: Path = ROOT) -> list[Path]:
    """Images the documentation shows that no entry of ``FIGURES`` makes."""
    made = {path.resolve() for _, outputs, _, _ in FIGURES for path in outputs_of(outputs, root)}
    return [path for path in shown_images(root) if path not in made]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("names", nargs="*", help="entries to make (default: all)")
    parser.add_argument("--skip-slow", action="store_true", help=f"leave out entries over {SLOW_MINUTES:g} minutes")
    parser.add_argument("--list", action="store_true", help="print the table and stop")
    parser.add_argument("--check", action="store_true", help="list shown images no entry makes, and stop")
    arguments = parser.parse_args()
    if arguments.list:
        for name, outputs, commands, minutes in FIGURES:
            print(f"{name:32s} {minutes:5.1f} min  {outputs}\n{'':45s}{commands}")
        return 0
    if arguments.check:
        missing = uncovered()
        for path in missing:
            print(f"no entry makes {path.relative_to(ROOT)}")
        print(f"{len(shown_images())} images shown, {len(missing)} without an entry")
        return 1 if missing else 0
    unknown = set(arguments.names) - {entry[0] for entry in FIGURES}
    if unknown:
        parser.error(f"no such entries: {', '.join(sorted(unknown))} (see --list)")
    chosen = [
        entry
        for entry in FIGURES
        if (entry[0] in arguments.names if arguments.names else not (arguments.skip_slow and entry[3] > SLOW_MINUTES))
    ]
    problems = []
    for name, outputs, commands, minutes in chosen:
        began = time.perf_counter()
        print(f"{name} (about {minutes:g} min) ...", flush=True)
        found = make(name, outputs, commands)
        problems += found
        print(f"  {'done' if not found else 'PROBLEM'} in {time.perf_counter() - began:.0f} s", flush=True)
    for problem in problems:
        print(problem, file=sys.stderr)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
