"""One table of every failure case and remedy, from the case sweeps' results.

    python -m experiments.failure_cases.collect     (after running each case's sweep.toml)

Writes table.md beside this file: per case and filter variant, the mean over the seeds (median NEES:
each run's median over its records, then the mean over the seeds; NIS: mean over the associated
observations; resampled: share of scans; optimum: the batch least-squares solution of the same log).
"""

import argparse
from pathlib import Path

import pandas as pd

HERE = Path(__file__).resolve().parent
CASES = ["default", "long_corridor", "wide_room", "narrow", "symmetric", "sparse_turns", "few_points"]
VARIANT = "slam.fastslam.version+slam.fastslam.NPARTICLES"
NAMES = {
    "1/100": "FastSLAM 1.0, 100 particles",
    "2/100": "FastSLAM 2.0, 100 particles",
    "2/1000": "FastSLAM 2.0, 1000 particles",
}


def main():
    rows = []
    for case in CASES:
        path = HERE / case / "results" / "results.csv"
        if not path.exists():
            continue
        table = pd.read_csv(path)
        for variant, group in table.groupby(VARIANT, sort=False):
            rows.append(
                {
                    "case": case,
                    "filter": NAMES.get(variant, variant),
                    "runs": len(group),
                    "ATE [cm]": 100 * group.ate_rmse.mean(),
                    "dead reckoning [cm]": 100 * group.reckoning_ate_rmse.mean(),
                    "ATE aligned [cm]": 100 * group.ate_aligned_rmse.mean(),
                    "map aligned [cm]": 100 * group.map_aligned_rmse.mean(),
                    "landmarks / true corners": f"{group.landmarks.mean():.1f} / {group.true_corners.iloc[0]}",
                    "ATE / optimum's": group.optimum_ratio.mean(),
                    "aligned / optimum's": group.optimum_aligned_ratio.mean(),
                    "spurious": group.spurious_landmarks.mean(),
                    "median NEES": group.median_nees.mean(),
                    "NIS mean": group.nis_mean.mean(),
                    "resampled": group.resampled_fraction.mean(),
                    "median ESS": group.ess_median.mean(),
                    "new per scan": group.new_per_scan.mean(),
                    "ambiguous per scan": group.ambiguous_per_scan.mean(),
                }
            )
    result = pd.DataFrame(rows)
    (HERE / "table.md").write_text(result.to_markdown(index=False, floatfmt=".2f") + "\n")
    print(result.to_markdown(index=False, floatfmt=".2f"))


if __name__ == "__main__":
    # No options; --help says what the script does (it rewrites its committed results).
    argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter).parse_args()
    main()
