"""Measure robots imported from SDF against references that do not use the SDF reader.

- Onshape-to-robot style URDFs (``tests/cad_models.cad_urdf``, loops closed exactly by
  ``tests/sdf_models.closed_urdf``) rewritten as SDF 1.4, 1.6 and 1.9
  (``tests/sdf_models.urdf_to_sdf``): against Pinocchio's model of the URDF with its loops
  as hard constraints in an exact KKT solve (``tests/test_import_urdf.PinReference``).
- Gazebo users' SDF of the presets ``simulator`` (6-UPS) and ``rus`` (6-RUS), universal
  joints and the platform the child of six balls (``tests/sdf_models.gazebo_sdf``, 1.4
  and 1.9): against the same preset written by the project's URDF writer and imported.

Prints the largest per-state relative error ``max_k |a_k - b_k| / max_k |b_k|`` over
``--states`` random states of the inverse dynamics (IDM) and of the direct dynamics for
the reference's efforts (DDM). Run from the repository root (a few seconds)::

    PYTHONPATH=src:tests python scripts/sdf_validation.py [--states 10]
"""

from __future__ import annotations

import argparse
import os
import tempfile
import warnings
from pathlib import Path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--states", type=int, default=10, help="random states per file")
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    os.environ.setdefault("STEWART_PIN_BACKEND", "pinocchio")

    from cad_models import cad_urdf
    from helpers import rel_error
    from sdf_models import closed_urdf, gazebo_sdf, urdf_to_sdf
    from test_import_mjcf import states
    from test_import_sdf import _u_cross_massless, actuated_of
    from test_import_urdf import RANGES, SOURCES, PinReference, pairs_of

    from stewart_pin import StewartRobot
    from stewart_pin.formats.urdf import write_urdf

    tmp = Path(tempfile.mkdtemp())
    print(f"{'file':52s} {'IDM':>9s} {'DDM':>9s}")
    for arch in SOURCES:
        worst = [0.0, 0.0]
        urdf = closed_urdf(cad_urdf(SOURCES[arch](), seed=1, digits=15))
        (tmp / "m.urdf").write_text(urdf)
        ref = PinReference(tmp / "m.urdf", pairs_of(), {})
        ref.S = (ref.S != 0) * 1.0  # SDF has no gears
        for version in ("1.4", "1.6", "1.9"):
            (tmp / "m.sdf").write_text(urdf_to_sdf(urdf, version, seed=2))
            robot = StewartRobot.from_sdf(tmp / "m.sdf", actuated=actuated_of(urdf))
            for T, V, A in states(robot, RANGES[arch], args.states, seed=3):
                q, v = ref.closed_state(T, V)
                gamma = ref.kkt(q, v, A=A)
                worst[0] = max(worst[0], rel_error(robot.inverse_dynamics(T, V, A), gamma))
                A_ref = ref.kkt(q, v, gamma=gamma)
                worst[1] = max(worst[1], rel_error(robot.direct_dynamics(T, V, gamma), A_ref))
        label = f"SDF 1.4/1.6/1.9 of a 6-{arch.upper()} URDF vs Pinocchio KKT"
        print(f"{label:52s} {worst[0]:9.1e} {worst[1]:9.1e}")
    for name, cross, ranges in (("simulator", 0, (0.05, 0.05)), ("rus", 1, (0.01, 0.03))):
        worst = [0.0, 0.0]
        d = _u_cross_massless(name, cross)
        path, _ = write_urdf(d, tmp / "w.urdf")
        reference = StewartRobot.from_urdf(path)
        for version in ("1.4", "1.9"):
            (tmp / "g.sdf").write_text(gazebo_sdf(d, version, seed=7))
            robot = StewartRobot.from_sdf(tmp / "g.sdf")
            for T, V, A in states(robot, ranges, args.states, seed=3):
                gamma = reference.inverse_dynamics(T, V, A)
                worst[0] = max(worst[0], rel_error(robot.inverse_dynamics(T, V, A), gamma))
                A_ref = reference.direct_dynamics(T, V, gamma)
                worst[1] = max(worst[1], rel_error(robot.direct_dynamics(T, V, gamma), A_ref))
        label = f"Gazebo-style SDF 1.4/1.9 of '{name}' vs its URDF import"
        print(f"{label:52s} {worst[0]:9.1e} {worst[1]:9.1e}")


if __name__ == "__main__":
    main()
