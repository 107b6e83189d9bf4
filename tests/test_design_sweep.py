"""Design studies, geometry sweeps on Dask (issue 22 item 4): the parallel table equals
the serial one, a failed geometry is a row, an unreachable scheduler a named error."""

from __future__ import annotations

import math

import numpy as np
import pytest

from stewart_pin import InputError, SchedulerError, design

GEOMETRIES = [
    *design.grid(base_radius=[0.09, 0.11], home_height=[0.14, 0.16]),
    {"platform_radius": 0.08, "stroke": (0.12, 0.2)},
    {"home_height": -1.0},  # cannot assemble: a row with its error
]
SETTINGS = design.SweepSettings(resolution=10, samples=40)


@pytest.fixture(scope="module")
def serial():
    return design.sweep(GEOMETRIES, SETTINGS, scheduler="serial", progress=False)


def test_parallel_table_equals_the_serial_one(serial, tmp_path):
    parallel = design.sweep(GEOMETRIES, SETTINGS, workers=2, processes=False, progress=False)
    a = serial.write_csv(tmp_path / "serial.csv").read_text()
    b = parallel.write_csv(tmp_path / "parallel.csv").read_text()
    assert a == b
    assert a.splitlines()[0] == (
        "base_radius,home_height,platform_radius,stroke,volume,volume_error,peak_effort,"
        "peak_speed,peak_power,error"
    )
    assert len(a.splitlines()) == 1 + len(GEOMETRIES)


def test_a_failed_geometry_is_a_row(serial):
    bad = serial.rows[-1]
    assert bad["error"].startswith("DescriptionError:") and "home_height" in bad["error"]
    assert math.isnan(bad["volume"])
    for row in serial.rows[:-1]:
        assert row["error"] == "" and row["volume"] > 0 and row["peak_effort"] > 0
    # each row is the geometry's own evaluation (the order kept)
    one = design.evaluate_geometry(GEOMETRIES[2], SETTINGS)
    assert one == serial.rows[2]


def test_pareto_front_by_brute_force(serial, tmp_path):
    a, b = serial.column("peak_effort"), serial.column("volume")
    front = set(serial.pareto().tolist())
    for i in range(len(a)):
        if not np.isfinite(a[i]):
            assert i not in front
            continue
        dominated = any(
            a[j] <= a[i] and b[j] >= b[i] and (a[j] < a[i] or b[j] > b[i])
            for j in range(len(a))
            if np.isfinite(a[j])
        )
        assert (i in front) == (not dominated)
    pytest.importorskip("matplotlib")
    serial.plot_pareto(tmp_path / "pareto.png")
    assert (tmp_path / "pareto.png").read_bytes()[:4] == b"\x89PNG"


def test_unreachable_scheduler_and_bad_input_are_named_errors():
    with pytest.raises(SchedulerError, match="cannot reach"):
        design.sweep(GEOMETRIES[:1], SETTINGS, scheduler="tcp://127.0.0.1:9", timeout=1.0)
    with pytest.raises(InputError):
        design.sweep([], SETTINGS, scheduler="serial")
    with pytest.raises(InputError):
        design.grid(base_radius=0.1)


def test_an_open_client_is_used_and_left_open(serial, tmp_path):
    from dask.distributed import Client, LocalCluster

    with LocalCluster(n_workers=1, processes=False, dashboard_address=None) as cluster:
        with Client(cluster) as client:
            table = design.sweep(GEOMETRIES[:2], SETTINGS, client=client, progress=False)
            assert client.status == "running"
    assert table.rows == serial.rows[:2]


def lowest_condition(robot):
    """A custom metric (module level: Dask pickles it by reference)."""
    return {"home_condition": float(robot.condition_number(robot.home_pose))}


def test_custom_metrics():
    table = design.sweep(
        GEOMETRIES, SETTINGS, scheduler="serial", progress=False, metrics=lowest_condition
    )
    assert table.columns[-2:] == ["home_condition", "error"]
    from stewart_pin import StewartRobot, symmetric_hexapod

    params = {**design.BASE_GEOMETRY, **GEOMETRIES[0]}
    c = StewartRobot(symmetric_hexapod(**params)).condition_number(
        StewartRobot(symmetric_hexapod(**params)).home_pose
    )
    assert table.rows[0]["home_condition"] == c
    assert math.isnan(table.rows[-1]["home_condition"]) and table.rows[-1]["error"]


def broken_metric(robot):
    """A custom metric with a bug: the row keeps its error, the sweep goes on."""
    raise ZeroDivisionError("division by zero in the user's metric")


def test_any_failure_is_a_row():
    table = design.sweep(
        GEOMETRIES[:2], SETTINGS, scheduler="serial", progress=False, metrics=broken_metric
    )
    assert [r["error"] for r in table.rows] == [
        "ZeroDivisionError: division by zero in the user's metric"
    ] * 2
    bad = design.sweep([{"no_such_key": 1.0}], SETTINGS, scheduler="serial", progress=False)
    assert bad.rows[0]["error"].startswith("TypeError:")


@pytest.mark.parametrize(
    "field, value",
    [("samples", -5), ("resolution", 0), ("seed", 1.5), ("accel", math.nan), ("backend", "x")],
)
def test_bad_sweep_settings_are_refused_once(field, value):
    """A bad setting was caught per geometry and written into every row (the sweep
    returned normally): now one named error when the settings are made."""
    with pytest.raises(InputError, match=field):
        design.SweepSettings(**{field: value})
