"""Measure imported robots against MuJoCo's and Pinocchio's own models of the same files.

For CAD-like files (``tests/cad_models.py``: odd body frames, rounded numbers, classes and
defaults, extra fixed bodies, hinge ``ref`` values, gears) of 6-UPS, 6-RUS and 6-PUS
robots with joint terms in every MJCF loop convention, of R-S-S, P-S-S and S-P-S legs,
and of onshape-to-robot style URDFs, prints the largest per-state relative error
``max_k |a_k - b_k| / max_k |b_k|`` over ``--states`` random states of:

- IDM: ``robot.inverse_dynamics(motor=True)`` of the imported robot against the exact KKT
  solve on MuJoCo's model of the file (``tests/helpers.mujoco_kkt``) or on Pinocchio's
  model of the URDF (``tests/test_import_urdf.PinReference``);
- DDM: ``robot.direct_dynamics`` against the same KKT solve's forward dynamics, for the
  reference's forces.

Run from the repository root (about a minute)::

    PYTHONPATH=src:tests python scripts/import_validation.py [--states 10]
"""

from __future__ import annotations

import argparse
import tempfile
import warnings
from pathlib import Path

import numpy as np


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--states", type=int, default=10, help="random states per file")
    args = parser.parse_args()
    warnings.simplefilter("ignore")

    import mujoco
    from cad_models import LOOPS, cad_mjcf, cad_urdf, ss_mjcf
    from helpers import mujoco_closed_state, mujoco_kkt, rel_error
    from test_import_mjcf import RANGES, SOURCES, states
    from test_import_urdf import ARMATURE, PinReference, pairs_of

    from stewart_pin import StewartRobot

    def ratios(robot: StewartRobot) -> np.ndarray:
        return np.array(
            [
                leg.joints[leg.actuated - 1].dynamics.transmission_ratio
                for leg in robot.general.legs
            ]
        )

    def mujoco_errors(xml: str, ranges, platform: str = "platform", no_spin=()) -> tuple:
        robot = StewartRobot.from_mjcf(xml, platform=platform)
        m = mujoco.MjModel.from_xml_string(xml)
        data = mujoco.MjData(m)
        worst_i = worst_d = 0.0
        for T, V, A in states(robot, ranges, args.states, seed=11):
            mujoco_closed_state(m, data, platform, T, V, no_spin=no_spin)
            g_ref = mujoco_kkt(m, data, platform, A=A)
            g = robot.inverse_dynamics(T, V, A, motor=True)
            worst_i = max(worst_i, rel_error(g, g_ref))
            A_ref = mujoco_kkt(m, data, platform, gamma=g_ref)
            worst_d = max(
                worst_d, rel_error(robot.direct_dynamics(T, V, g * ratios(robot)), A_ref)
            )
        return robot.architecture, worst_i, worst_d

    print(f"{'file':34s} {'legs':8s} {'IDM':>9s} {'DDM':>9s}")
    for arch, make in SOURCES.items():
        robot_src = make()
        for loops in LOOPS:
            kind, e_i, e_d = mujoco_errors(cad_mjcf(robot_src, loops, seed=3), RANGES[arch])
            print(f"MJCF {arch:4s} {loops:24s} {kind:8s} {e_i:9.1e} {e_d:9.1e}")
    sources = {"rss": (SOURCES["rus"](), RANGES["rus"]), "pss": (SOURCES["pus"](), RANGES["pus"])}
    sources["sps"] = (StewartRobot.from_preset("desktop").general, (0.005, 0.05))
    for kind_ss, (robot_src, ranges) in sources.items():
        for connect in (True, False):
            rods = [f"leg{i}_rod" if kind_ss != "sps" else f"leg{i}_cylinder" for i in range(1, 7)]
            if kind_ss == "sps":
                rods += [f"leg{i}_piston" for i in range(1, 7)]
            xml = ss_mjcf(robot_src, kind_ss, seed=2, connect=connect)
            spin = [(r, (0, 0, 1)) for r in rods]
            kind, e_i, e_d = mujoco_errors(xml, ranges, no_spin=spin)
            where = "connects" if connect else "platform in tree"
            print(f"MJCF {kind_ss:4s} {where:24s} {kind:8s} {e_i:9.1e} {e_d:9.1e}")
    folder = Path(tempfile.mkdtemp())
    for arch, make in SOURCES.items():
        for style in ("floating", "tree-hinges"):
            path = folder / f"{arch}-{style}.urdf"
            path.write_text(cad_urdf(make(), style, seed=1))
            robot = StewartRobot.from_urdf(path, armature=ARMATURE)
            pairs = [
                p for p in pairs_of() if not (style == "tree-hinges" and p[0] == "closing_1_1")
            ]
            ref = PinReference(path, pairs, ARMATURE)
            worst_i = worst_d = 0.0
            for T, V, A in states(robot, RANGES[arch], args.states, seed=11):
                q, v = ref.closed_state(T, V)
                g_ref = ref.kkt(q, v, A=A)
                g = robot.inverse_dynamics(T, V, A, motor=True)
                worst_i = max(worst_i, rel_error(g, g_ref))
                A_ref = ref.kkt(q, v, gamma=g_ref)
                A_got = robot.direct_dynamics(T, V, g * ratios(robot))
                worst_d = max(worst_d, rel_error(A_got, A_ref))
            print(
                f"URDF {arch:4s} {style:24s} {robot.architecture:8s} {worst_i:9.1e} {worst_d:9.1e}"
            )


if __name__ == "__main__":
    main()
