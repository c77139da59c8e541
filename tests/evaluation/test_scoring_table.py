"""The slam command's error table without pandas: the same text and records pandas gives."""

import math

import numpy as np
import pandas as pd
import pytest

from mazeslam.data.loaded_run import load_run
from mazeslam.evaluation.scoring import error_rows, error_table, markdown_table, score_run
from mazeslam.pipeline import SlamConfig, run_slam


def _frame(rows: dict) -> pd.DataFrame:
    return pd.DataFrame([{"estimator": name, **row} for name, row in rows.items()]).set_index("estimator")


@pytest.mark.parametrize(
    "rows",
    [
        {"a": {"x": 1.0, "longer_column": math.nan}, "a much longer name": {"x": -12.34567, "longer_column": 0.5}},
        {"dead reckoning": {"ate_rmse": 123456.789, "mean_nees": math.inf}, "b": {"ate_rmse": 0.0, "mean_nees": 2.0}},
        {"only": {"v": math.nan}},
        {"n": {"v": -0.00001, "w": 1e-9}, "m": {"v": 3.0, "w": -math.inf}},
    ],
)
def test_markdown_table_prints_what_pandas_prints(rows):
    assert markdown_table(rows) == _frame(rows).to_markdown(floatfmt=".4f")


def test_a_scored_run_gives_pandas_text_records_and_table(default_run):
    run = load_run(default_run.log_path)
    score = score_run(run, run_slam(run, SlamConfig(), progress=False))
    assert score is not None
    table = score.table
    assert score.markdown() == table.to_markdown(floatfmt=".4f")
    expected = table.reset_index().to_dict(orient="records")
    assert [row.keys() for row in score.row_records()] == [row.keys() for row in expected]
    np.testing.assert_array_equal(
        [list(row.values())[1:] for row in score.row_records()], [list(row.values())[1:] for row in expected]
    )
    assert score.ate() == table.loc[score.mean_row, "ate_rmse"] > 0
    nees = table["mean_nees"]
    assert nees.notna().sum() == 1 and nees[score.mean_row] == score.nees_summary["mean"]


def test_error_table_is_error_rows_as_a_frame(default_run):
    run = load_run(default_run.log_path)
    truth = run.truth
    shifted = truth + [0.03, -0.04, 0.0]  # every position 5 cm off, aligned away
    rows = error_rows({"shifted": shifted}, truth)
    assert rows["shifted"]["ate_rmse"] == pytest.approx(0.05)
    assert rows["shifted"]["aligned_rmse"] == pytest.approx(0.0, abs=1e-9)
    pd.testing.assert_frame_equal(error_table({"shifted": shifted}, truth), _frame(rows))
