"""Per-body gravity compensation (issue 21, item 5): the description's
``platform_gravcomp`` and ``leg_gravcomp`` (the fraction ``c`` of a body's weight removed:
its weight is ``(1 - c) m g`` at its centre of mass), set by the importers from MJCF
``gravcomp`` and SDF ``<gravity>false</gravity>``, in every model.

Independent references:

- MuJoCo's exact KKT solve on the MJCF file (``helpers.mujoco_kkt``: MuJoCo applies
  ``gravcomp`` as a passive force), for the IDM and the DDM, on the reference and the
  compiled backends;
- Pinocchio's constrained tree of the URDF an SDF file was written from, with the
  compensating forces ``-m g`` at the centres of mass of its ``<gravity>false</gravity>``
  links as external forces (``fext`` of ``pin.rnea``, written here from the URDF text);
- analytic: compensation 1 on every body is the robot without gravity; compensation 0 is
  the robot as before (files, cache key, outputs unchanged); power balance
  ``Gamma . qdot_a = dE/dt + dissipated`` by central differences of the energy;
- the regressor against the constrained tree's inverse dynamics (``W chi``).
"""

from __future__ import annotations

import re
import warnings
import xml.etree.ElementTree as ET

import numpy as np
import pinocchio as pin
import pytest
from cad_models import cad_urdf
from helpers import rel_error, urdf_weights, weight_removal_torques
from sdf_models import closed_urdf, urdf_to_sdf
from test_import_mjcf import differences
from test_import_side_features import _check
from test_import_urdf import RANGES, SOURCES, PinReference, pairs_of

from stewart_pin import (
    FileFormatError,
    GravityCompensationError,
    ModelImportError,
    ModelImportWarning,
    RobotDescription,
    StewartRobot,
)
from stewart_pin.check.leg_chain_tree import (
    GeneralTreeSolver,
    reference_direct_dynamics,
    reference_energy,
    reference_inverse_dynamics,
)
from stewart_pin.codegen._identity import library_identity
from stewart_pin.description.leg_chain_hexapod import general_from_description
from stewart_pin.description.presets import preset
from stewart_pin.dynamics.regressor import standard_parameters
from stewart_pin.formats.mjcf import mjcf_string
from stewart_pin.formats.urdf import write_urdf
from stewart_pin.importers import import_mjcf, import_sdf

pytestmark = pytest.mark.filterwarnings("ignore::stewart_pin.ModelImportWarning")

TOL = 1e-10  # relative: the references are exact solves on the same model

#: MJCF bodies given a gravcomp (the platform, rods and other links, different factors).
GRAVCOMP = {"platform": 0.7, "leg1_link2": 1.0, "leg3_link3": 0.3, "leg6_link1": 0.5}


def _compensated(desc: RobotDescription, seed: int = 0) -> RobotDescription:
    c = np.random.default_rng(seed).uniform(0.0, 1.0, (6, 3))
    c[0] = 0.0  # one leg without
    c[1, 2] = 1.0  # a rod weightless
    return desc.replace(platform_gravcomp=0.4, leg_gravcomp=c)


# ---------------------------------------------------------------------- the description
def test_description_field_validated_and_round_trips(tmp_path):
    d = preset("rus")
    c = _compensated(d)
    assert c.platform_gravcomp == 0.4 and c.leg_gravcomp.shape == (6, 3)
    for suffix in (".toml", ".json"):
        back = RobotDescription.read(c.write(tmp_path / f"r{suffix}"))
        assert back.to_dict() == c.to_dict()  # exact: floats by repr
        assert back.platform_gravcomp == 0.4
        np.testing.assert_array_equal(back.leg_gravcomp, c.leg_gravcomp)
    # absent when all zero: the files of robots without it are unchanged
    assert "leg_gravcomp" not in d.to_dict() and "platform_gravcomp" not in d.to_dict()
    zero = d.replace(platform_gravcomp=0.0, leg_gravcomp=np.zeros((6, 3)))
    assert zero.to_dict() == d.to_dict()
    assert d.write(tmp_path / "a.toml").read_text() == zero.write(tmp_path / "b.toml").read_text()
    bad = [
        ({"platform_gravcomp": -0.1}, "gravity compensation of the platform must be in"),
        ({"platform_gravcomp": 1.5}, r"platform must be in \[0, 1\].*got 1.5"),
        ({"platform_gravcomp": float("nan")}, "platform must be in"),
        ({"platform_gravcomp": "half"}, "platform must be a number"),
        ({"platform_gravcomp": True}, "platform must be a number"),
        ({"leg_gravcomp": [[0.0] * 3] * 5}, "six lists"),
        ({"leg_gravcomp": [[0.0] * 3] * 5 + [[0.0, 0.0]]}, "leg 6 must be 3 factors"),
        ({"leg_gravcomp": [[0.0] * 3] * 5 + [[0.0, 2.0, 0.0]]}, "leg 6 link 2 must be in"),
        ({"leg_gravcomp": [[0.0] * 3] * 5 + [[0.0, float("inf"), 0.0]]}, "leg 6 link 2"),
    ]
    for change, message in bad:
        with pytest.raises(GravityCompensationError, match=message) as info:
            d.replace(**change)
        assert info.value.body in ("platform", "leg_gravcomp", "leg 6 link 2")
    # the resolved view the dynamics read checks them too
    with pytest.raises(GravityCompensationError, match="leg 1 link 1 must be in"):
        general_from_description(c).replace(leg_gravcomp=np.full((6, 3), -1.0))
    # in a file: the key's line quoted
    text = c.write(tmp_path / "c.toml").read_text()
    broken = text.replace("platform_gravcomp = 0.4", "platform_gravcomp = 4.0")
    (tmp_path / "d.toml").write_text(broken)
    line = broken.splitlines().index("platform_gravcomp = 4.0") + 1
    with pytest.raises(FileFormatError, match=rf"line {line}: gravity compensation"):
        RobotDescription.read(tmp_path / "d.toml")


def test_an_ideal_ups_with_compensation_takes_the_leg_chain_path():
    """The ideal 6-UPS form has one gravity for all bodies: with a compensation its legs
    become explicit ``ups`` legs (the leg-chain path, closed forms kept), the robot the
    same otherwise (equal efforts without compensation)."""
    d = preset("paper")
    assert d.is_ideal_ups
    c = d.replace(platform_gravcomp=0.0, leg_gravcomp=np.zeros((6, 3)))
    assert c.is_ideal_ups  # zero: unchanged
    c = _compensated(d)
    assert not c.is_ideal_ups and c.architecture == "ups" and c.stroke is None
    back = c.replace(platform_gravcomp=0.0, leg_gravcomp=None)
    robot, ref = StewartRobot(back), StewartRobot(d)
    P, V, A = ref.sample_states(3, 5)
    assert rel_error(robot.inverse_dynamics(P, V, A), ref.inverse_dynamics(P, V, A)) < 1e-12


# ---------------------------------------------------------------------- every model
@pytest.mark.parametrize("name", ["paper", "rus", "random-custom-5"])
def test_reference_path_and_regressor_equal_the_constrained_tree(name):
    """IDM, DDM, energy and the regressor of a robot with compensations on some bodies
    against the tree with the compensating forces as external forces."""
    desc = _compensated(preset(name))
    robot = StewartRobot(desc)
    P, V, A = robot.sample_states(4, 7)
    q = robot.inverse_geometry(P, check_limits=False)
    solver = GeneralTreeSolver(general_from_description(desc))
    gamma_ref = reference_inverse_dynamics(solver, P, V, A, q)
    gamma = robot.inverse_dynamics(P, V, A, backend="pinocchio")
    assert rel_error(gamma, gamma_ref) < TOL
    uncompensated = StewartRobot(preset(name)).inverse_dynamics(P, V, A, backend="pinocchio")
    assert rel_error(uncompensated, gamma_ref) > 1e-2  # the compensation matters
    accel_ref = reference_direct_dynamics(solver, P, V, gamma_ref, q)
    assert rel_error(robot.direct_dynamics(P, V, gamma_ref, backend="pinocchio"), accel_ref) < TOL
    k, u, _ = reference_energy(solver, P, V, q)
    np.testing.assert_allclose(robot.energy(P, V), k + u, rtol=TOL, atol=TOL * np.abs(k + u).max())
    W = robot.regressor(P, V, A)
    assert rel_error(W @ standard_parameters(desc), gamma_ref) < TOL


def test_compiled_model_and_its_cache_key():
    desc = _compensated(preset("rus"), seed=3)
    robot = StewartRobot(desc)
    P, V, A = robot.sample_states(4, 9)
    q = robot.inverse_geometry(P, check_limits=False)
    solver = GeneralTreeSolver(general_from_description(desc))
    gamma_ref = reference_inverse_dynamics(solver, P, V, A, q)
    assert rel_error(robot.inverse_dynamics(P, V, A, backend="compiled"), gamma_ref) < TOL
    accel_ref = reference_direct_dynamics(solver, P, V, gamma_ref, q)
    assert rel_error(robot.direct_dynamics(P, V, gamma_ref, backend="compiled"), accel_ref) < TOL
    # the cache key covers the compensation (a robot differing only there is another library)
    other = desc.replace(platform_gravcomp=0.5)
    assert library_identity(desc, "models") != library_identity(other, "models")
    c = desc.leg_gravcomp.copy()
    c[4, 1] = 0.0 if c[4, 1] else 0.5
    assert library_identity(desc, "models") != library_identity(
        desc.replace(leg_gravcomp=c), "models"
    )


def test_compensation_one_on_every_body_is_the_robot_without_gravity():
    """Analytic: every weight removed = no gravity (springs and joint terms kept)."""
    d = preset("rus")
    full = StewartRobot(d.replace(platform_gravcomp=1.0, leg_gravcomp=np.ones((6, 3))))
    free = StewartRobot(d.replace(gravity=np.zeros(3)))
    P, V, A = free.sample_states(4, 3)
    for backend in ("pinocchio", "compiled"):
        got = full.inverse_dynamics(P, V, A, backend=backend)
        assert rel_error(got, free.inverse_dynamics(P, V, A, backend="pinocchio")) < TOL
        hold = full.gravity_compensation(P)
        assert rel_error(hold, free.gravity_compensation(P)) < TOL
    # and without springs the efforts holding it still are zero
    no_springs = StewartRobot(
        full.description.replace(
            legs=tuple(
                leg.with_dynamics([type(j.dynamics)() for j in leg.joints]) for leg in d.legs
            )
        )
    )
    assert np.abs(no_springs.gravity_compensation(P)).max() < 1e-12 * 9.81
    # the energy: no gravitational potential left
    e_full, e_free = full.energy(P, V), free.energy(P, V)
    np.testing.assert_allclose(e_full, e_free, rtol=1e-12, atol=1e-12 * np.abs(e_free).max())


def test_power_balance_with_compensation():
    """``Gamma . qdot_a = dE/dt + dissipated``, E with the compensated weights' potential,
    along an exact SE(3) trajectory (central differences)."""
    desc = _compensated(preset("rus"), seed=5)
    robot = StewartRobot(desc)
    T0, V0, A0 = (x[0] for x in robot.sample_states(1, 2))
    R0, p0 = T0[:3, :3], T0[:3, 3]

    def state(t: float):
        # constant angular acceleration about a fixed axis keeps the exponential exact
        w0 = V0[3:]
        T = np.eye(4)
        T[:3, :3] = pin.exp3(w0 * t) @ R0
        T[:3, 3] = p0 + V0[:3] * t + 0.5 * A0[:3] * t**2
        return T, np.r_[V0[:3] + A0[:3] * t, w0]

    def energy(t: float) -> float:
        return float(robot.energy(*state(t)))

    dt = 1e-5  # truncation O(dt^2): 2e-8 relative here (1.9e-6 at 1e-4), round-off eps E / dt
    dE = (energy(dt) - energy(-dt)) / (2 * dt)
    A = np.r_[A0[:3], np.zeros(3)]
    rates = robot.general_dynamics.actuator_rates(T0, V0)
    power = robot.inverse_dynamics(T0, V0, A, backend="pinocchio") @ rates
    lost = robot.dissipated_power(T0, V0)
    scale = abs(dE) + abs(lost) + abs(power)
    assert abs(power - dE - lost) < 1e-6 * scale


def test_compensation_zero_changes_nothing():
    d = preset("rus")
    z = d.replace(platform_gravcomp=0.0, leg_gravcomp=[[0.0] * 3] * 6)
    assert library_identity(d, "models") == library_identity(z, "models")
    a, b = StewartRobot(d), StewartRobot(z)
    P, V, A = a.sample_states(3, 1)
    np.testing.assert_array_equal(
        a.inverse_dynamics(P, V, A, backend="pinocchio"),
        b.inverse_dynamics(P, V, A, backend="pinocchio"),
    )
    np.testing.assert_array_equal(a.energy(P, V), b.energy(P, V))


# ---------------------------------------------------------------------- MJCF
def _mjcf_with_gravcomp() -> str:
    xml = mjcf_string(preset("rus"))
    for body, c in GRAVCOMP.items():
        xml, n = re.subn(rf'<body name="{body}"', f'<body name="{body}" gravcomp="{c}"', xml)
        assert n == 1
    return xml


@pytest.mark.parametrize("backend", ["pinocchio", "compiled"])
def test_mjcf_gravcomp_on_some_bodies_matches_mujoco(backend):
    pytest.importorskip("mujoco")
    xml = _mjcf_with_gravcomp()
    result = import_mjcf(xml)
    desc = result.description
    assert desc.platform_gravcomp == 0.7
    expected = np.zeros((6, 3))
    expected[0, 1], expected[2, 2], expected[5, 0] = 1.0, 0.3, 0.5
    np.testing.assert_array_equal(desc.leg_gravcomp, expected)
    assert "gravity compensation of some bodies" in str(result.report)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ModelImportWarning)
        robot = StewartRobot(desc)
    _check(xml, robot, backend=backend, ddm=True)


def test_mjcf_writer_writes_gravcomp_and_reads_it_back():
    """The written file: ``gravcomp`` on those bodies, MuJoCo's KKT on it equal to the
    robot, and the import of it the same description."""
    pytest.importorskip("mujoco")
    desc = import_mjcf(_mjcf_with_gravcomp()).description
    written = mjcf_string(desc)
    assert 'gravcomp="0.7"' in written and 'gravcomp="0.3"' in written
    _check(written, StewartRobot(desc), n=2, backend="pinocchio", ddm=True)
    back = import_mjcf(written).description
    assert differences(back, desc) == []


def test_mjcf_bodies_of_one_link_with_different_compensations_are_refused():
    xml = mjcf_string(preset("rus"))
    # a body fixed in leg 2's rod, with another compensation than the rod's
    extra = (
        '<body name="sensor" gravcomp="1">'
        '<inertial pos="0 0 0.01" mass="0.05" diaginertia="1e-5 1e-5 1e-5"/></body>'
    )
    xml = re.sub(r'(<body name="leg2_link3"[^>]*>)', r"\1" + extra, xml, count=1)
    with pytest.raises(ModelImportError, match=r"'leg2_link3', 'sensor'.*different gravity comp"):
        import_mjcf(xml)


# ---------------------------------------------------------------------- SDF
class _CompensatedReference(PinReference):
    """The URDF in Pinocchio with the forces ``-m g`` at the centres of mass of ``links``
    (their ``<gravity>false</gravity>`` in the SDF) as external forces."""

    def __init__(self, path, pairs, links):
        super().__init__(path, pairs, {})
        self.forces = urdf_weights(self.model, path, links)

    def _bias(self, q, v):
        jt_f = weight_removal_torques(self.model, self.data, q, self.forces)
        c, drift, plat = super()._bias(q, v)
        return c - jt_f, drift, plat


def _gravity_off(sdf: str, links) -> str:
    for name in links:
        sdf, n = re.subn(
            rf'(<link name="{name}">.*?)</link>', r"\1<gravity>false</gravity></link>", sdf,
            count=1, flags=re.S,
        )  # fmt: skip
        assert n == 1, name
    return sdf


@pytest.mark.parametrize("arch", ["rus", "ups"])
def test_sdf_gravity_false_links_match_pinocchio_with_compensating_forces(arch, tmp_path):
    """An SDF 1.9 whose platform (and the camera fixed on it), a rod and a link with a
    housing fixed to it have ``<gravity>false</gravity>``."""
    urdf = closed_urdf(cad_urdf(SOURCES[arch](), seed=1, digits=15))
    (tmp_path / "robot.urdf").write_text(urdf)
    links = ["platform", "camera", "leg2_link3", "leg5_link1", "leg5_housing"]
    sdf = _gravity_off(urdf_to_sdf(urdf, "1.9", seed=2), links)
    (tmp_path / "robot.sdf").write_text(sdf)
    actuated = [t.find("joint").get("name") for t in ET.fromstring(urdf).findall("transmission")]
    result = import_sdf(tmp_path / "robot.sdf", actuated)
    desc = result.description
    assert desc.platform_gravcomp == 1.0
    expected = np.zeros((6, 3))  # the legs in the actuators' order: found by their bodies
    for k, leg in enumerate(desc.source.legs):
        for j, bodies in enumerate(leg.bodies):
            if bodies in ("leg2_link3", "leg5_link1, leg5_housing"):
                expected[k, j] = 1.0
    assert np.count_nonzero(expected) == 2
    np.testing.assert_array_equal(desc.leg_gravcomp, expected)
    assert "weights removed (gravity compensation 1)" in str(result.report)
    robot = StewartRobot(desc)
    ref = _CompensatedReference(tmp_path / "robot.urdf", pairs_of(), links)
    ref.S = (ref.S != 0).astype(float)  # SDF has no gears: the joints' efforts
    rng = np.random.default_rng(3)
    lo, hi = RANGES[arch]
    for _ in range(3):
        T = robot.home_pose
        T[:3, 3] += rng.uniform(-lo, lo, 3)
        T[:3, :3] = pin.exp3(rng.uniform(-hi, hi, 3)) @ T[:3, :3]
        V, A = rng.normal(size=6) * 0.1, rng.normal(size=6)
        q, v = ref.closed_state(T, V)
        gamma_ref = ref.kkt(q, v, A=A)
        gamma = robot.inverse_dynamics(T, V, A)
        assert rel_error(gamma, gamma_ref) < TOL, f"IDM {rel_error(gamma, gamma_ref):.2e}"
        A_ref = ref.kkt(q, v, gamma=gamma_ref)
        assert (
            rel_error(robot.direct_dynamics(T, V, gamma_ref), A_ref) < 1e-9
        )  # see test_import_sdf
    # the platform without the camera fixed on it: one link, two compensations
    half = _gravity_off(urdf_to_sdf(urdf, "1.9", seed=2), ["platform"])
    (tmp_path / "half.sdf").write_text(half)
    with pytest.raises(ModelImportError, match=r"'platform', 'camera'|'camera', 'platform'"):
        import_sdf(tmp_path / "half.sdf", actuated)


# ---------------------------------------------------------------------- URDF
def test_urdf_sidecar_records_the_compensation(tmp_path):
    """URDF has no such field: the sidecar's ``gravcomp`` (link -> factor), read back."""
    desc = _compensated(preset("rus"), seed=2)
    urdf, sidecar = write_urdf(desc, tmp_path / "r.urdf")
    assert '"gravcomp"' in sidecar.read_text()
    back = StewartRobot.from_urdf(urdf).description
    assert differences(back, desc) == []
    _, side = write_urdf(preset("rus"), tmp_path / "p.urdf")
    assert "gravcomp" not in side.read_text()
    text = sidecar.read_text().replace('"leg2_link3": 1.0', '"leg2_link3": 3.0')
    sidecar.write_text(text)
    with pytest.raises(FileFormatError, match="'leg2_link3' must be a number in"):
        StewartRobot.from_urdf(urdf)
