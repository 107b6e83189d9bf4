"""Model files of general-leg robots (6-UPS with offset U-joints, 6-RUS, 6-PUS, custom).

Independent references:
- the URDF and its sidecar, read back by Pinocchio's URDF parser
  (:func:`stewart_pin.models.pinocchio_models.load_tree`), give the same constrained
  dynamics as the tree built with the Pinocchio API (:mod:`stewart_pin.check.leg_chain_tree`)
  to 1e-12;
- the MJCF, loaded in MuJoCo: inverse dynamics by a KKT solve on MuJoCo's own mass matrix
  (``mj_fullM``, armature included), bias and passive forces (``qfrc_bias``,
  ``qfrc_passive``: damping and springs) and loop Jacobians (``mj_jacSite`` differences,
  checked against the equality rows of ``efc_J``; ``mj_jacDot`` for their drift), the loops
  as hard constraints, equals :class:`GeneralDynamics`' to 1e-9. MuJoCo's ``frictionloss``
  is a constraint of its soft solver, not a smooth ``Fc sign(qdot)`` term: these robots
  have their Coulomb coefficients set to 0 for the comparison (every other joint term is
  non-zero: armature with rotor inertia through gears and screws, viscous friction,
  dampers, springs off their rest positions);
- ``mj_forward`` (MuJoCo's soft loops) against :meth:`GeneralDynamics.direct_dynamics`,
  within the accuracy ``docs/closures.md`` states for general legs.
"""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pinocchio as pin
import pytest
from helpers import mujoco_leg_dofs, mujoco_set_loop_state

from stewart_pin.check.leg_chain_tree import (
    GeneralTreeSolver,
    reference_direct_dynamics,
    reference_inverse_dynamics,
)
from stewart_pin.description.inertia import khalil_from_urdf_inertial, urdf_inertial_from_khalil
from stewart_pin.description.leg_chain_hexapod import GeneralHexapod
from stewart_pin.description.leg_chain_presets import (
    pus_preset,
    random_hexapod,
    rus_preset,
    ups_offset_preset,
)
from stewart_pin.description.presets import preset
from stewart_pin.dynamics.leg_chain_dynamics import GeneralDynamics
from stewart_pin.exceptions import FileFormatError, LegJointLimitError, LegReachError
from stewart_pin.formats.mjcf import (
    LOOP_SOLIMP,
    LOOP_SOLREF,
    mjcf_string,
    mujoco_inertials,
    mujoco_qpos,
    write_mjcf,
)
from stewart_pin.formats.urdf import (
    JOINT_TERMS_KEY,
    URDF_UNBOUNDED,
    is_general,
    parse_joint_terms,
    read_closures,
    urdf_string,
    write_urdf,
)
from stewart_pin.kinematics.leg_chains import inverse_geometry
from stewart_pin.models.pinocchio_models import TreeModel, load_tree

#: The direct model through the URDF: its placements pass through rpy angles (round-off
#: 1e-16), which the constrained solve of the small RUS legs amplifies to about 1e-12.
DDM_TOL = 1e-11
PRESETS = {"rus": rus_preset, "pus": pus_preset, "ups-offset": ups_offset_preset}
RANDOM = [("rus", 0), ("rus", 1), ("pus", 0), ("pus", 1), ("ups-offset", 0), ("custom", 0)]
#: Workspace ranges per architecture (translation [m], rotation [rad]) around home.
RANGES = {"ups": (0.03, 0.1), "ups-offset": (0.03, 0.1), "rus": (0.003, 0.03)}
RANGES |= {"pus": (0.02, 0.1), "custom": (0.02, 0.1)}
PRESET_RANGES = {"rus": (0.003, 0.03), "pus": (0.01, 0.05), "ups-offset": (0.005, 0.05)}

_CACHE: dict[str, GeneralHexapod] = {}


def robot(name: str) -> GeneralHexapod:
    """A preset (``rus``...) or a random robot (``random-rus-0``...)."""
    if name not in _CACHE:
        if name in PRESETS:
            _CACHE[name] = PRESETS[name]()
        else:
            kind, seed = name.removeprefix("random-").rsplit("-", 1)
            _CACHE[name] = random_hexapod(kind, int(seed))
    return _CACHE[name]


def kind_of(name: str) -> str:
    return name if name in PRESETS else name.removeprefix("random-").rsplit("-", 1)[0]


ROBOTS = [*PRESETS, *(f"random-{k}-{s}" for k, s in RANDOM)]


def without_coulomb(h: GeneralHexapod) -> GeneralHexapod:
    return h.with_joint_dynamics(
        [[replace(j.dynamics, coulomb=0.0) for j in leg.joints] for leg in h.legs]
    )


def states(name: str, n: int, seed: int):
    """``n`` random states around home inside every joint limit: poses, twists and
    classical accelerations, and the legs' joint values (n, 6, 3)."""
    h = robot(name)
    tr, rot = PRESET_RANGES[name] if name in PRESETS else RANGES[kind_of(name)]
    rng = np.random.default_rng(seed)
    out = []
    while len(out) < n:
        T = np.array(h.home_pose)
        T[:3, 3] += rng.uniform(-tr, tr, 3)
        T[:3, :3] = pin.exp3(rng.uniform(-rot, rot, 3)) @ T[:3, :3]
        try:
            q = inverse_geometry(h, T)
        except (LegReachError, LegJointLimitError):
            continue
        scale = np.r_[[tr] * 3, [rot] * 3]
        out.append((T, 5 * scale * rng.normal(size=6), 30 * scale * rng.normal(size=6), q))
    return [np.array(x) for x in zip(*out, strict=True)]


def rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.abs(a - b).max() / np.abs(b).max())


# --- URDF and sidecar ----------------------------------------------------------------------


def test_dispatch_keeps_6ups_files():
    desc = preset("desktop")
    assert not is_general(desc)
    assert "leg1_q3" in urdf_string(desc) and "joint_terms" not in urdf_string(desc)
    assert is_general(rus_preset())


def test_deprecated_general_modules_warn_and_write_the_same_files(tmp_path):
    """The former twins ``formats.general_urdf`` / ``general_mjcf`` (issue 19) keep their
    names: each warns, naming its new place, and gives what the one writer gives."""
    import stewart_pin.formats as formats
    from stewart_pin.formats import general_mjcf, general_urdf

    h = rus_preset()
    with pytest.warns(DeprecationWarning, match=r"stewart_pin\.formats\.urdf_string"):
        assert formats.general_urdf_string(h) == urdf_string(h)
    with pytest.warns(DeprecationWarning, match=r"stewart_pin\.formats\.mjcf_string"):
        assert formats.general_mjcf_string(h, True) == mjcf_string(h, True)
    with pytest.warns(DeprecationWarning, match=r"stewart_pin\.formats\.write_urdf"):
        old = general_urdf.write_general_urdf(h, tmp_path / "old.urdf")
    new = write_urdf(h, tmp_path / "new.urdf")
    assert old[0].read_text() == new[0].read_text()
    assert json.loads(old[1].read_text()) | {"urdf": ""} == json.loads(new[1].read_text()) | {
        "urdf": ""
    }
    with pytest.warns(DeprecationWarning, match=r"stewart_pin\.formats\.write_mjcf"):
        path = general_mjcf.write_general_mjcf(h, tmp_path / "old.xml")
    assert path.read_text() == mjcf_string(h)
    with pytest.warns(DeprecationWarning, match=r"stewart_pin\.formats\.urdf\.parse_joint_terms"):
        assert general_urdf.parse_joint_terms is parse_joint_terms
    with pytest.warns(DeprecationWarning, match=r"stewart_pin\.formats\.mjcf\.mujoco_inertials"):
        assert general_mjcf.general_mujoco_inertials is mujoco_inertials
    with pytest.raises(AttributeError, match="no_such_name"):
        _ = general_urdf.no_such_name


@pytest.mark.parametrize("name", ROBOTS)
def test_urdf_tree_equals_reference_tree(name, tmp_path):
    """Pinocchio's URDF parser, the sidecar's closures and armatures: the same constrained
    dynamics as the tree built with the API (every joint term, Coulomb included)."""
    h = robot(name)
    urdf, sidecar = write_urdf(h, tmp_path / f"{name}.urdf")
    assert sidecar.name == f"{name}.closures.json"
    tree = load_tree(urdf)
    assert isinstance(tree, TreeModel) and (tree.model.nq, tree.model.nv) == (25, 24)
    from_files = GeneralTreeSolver(h, tree)  # type: ignore[arg-type]
    direct = GeneralTreeSolver(h)
    np.testing.assert_array_equal(
        tree.actuated_v_index, tree.leg_v_index[np.arange(6), h.actuated]
    )
    np.testing.assert_allclose(tree.model.gravity.linear, h.gravity, rtol=0, atol=0)
    T, V, A, Q = states(name, 4, seed=1)
    g_files = reference_inverse_dynamics(from_files, T, V, A, Q)
    g_api = reference_inverse_dynamics(direct, T, V, A, Q)
    assert rel(g_files, g_api) < 1e-12
    a_files = reference_direct_dynamics(from_files, T, V, g_api, Q)
    a_api = reference_direct_dynamics(direct, T, V, g_api, Q)
    assert rel(a_files, a_api) < DDM_TOL, rel(a_files, a_api)
    np.testing.assert_allclose(a_api, A, rtol=0, atol=1e-9 * np.abs(A).max())


@pytest.mark.parametrize("name", ["rus", "pus", "random-custom-0"])
def test_urdf_joints_limits_and_dynamics(name):
    h = robot(name)
    model = pin.buildModelFromXML(urdf_string(h))
    for i, leg in enumerate(h.legs, start=1):
        for j, joint in enumerate(leg.joints, start=1):
            jid = model.getJointId(f"leg{i}_q{j}")
            kind = "JointModelRZ" if joint.revolute else "JointModelPZ"
            assert model.joints[jid].shortname() == kind
            iv, iq = model.idx_vs[jid], model.idx_qs[jid]
            d = joint.dynamics
            assert model.damping[iv] == d.viscous + d.damping
            assert model.friction[iv] == d.coulomb
            lo = joint.lower if np.isfinite(joint.lower) else -URDF_UNBOUNDED
            hi = joint.upper if np.isfinite(joint.upper) else URDF_UNBOUNDED
            assert (model.lowerPositionLimit[iq], model.upperPositionLimit[iq]) == (lo, hi)
            # the link's inertial: the description's parameters, exactly
            a = model.inertias[jid]
            b = khalil_from_urdf_inertial(*urdf_inertial_from_khalil(h.leg_inertia[i - 1, j - 1]))
            np.testing.assert_allclose(
                [a.mass, *(a.mass * a.lever)], [b[9], *b[6:9]], rtol=1e-14, atol=1e-17
            )


def test_sidecar_content(tmp_path):
    h = random_hexapod("rus", 2)
    _, sidecar = write_urdf(h, tmp_path / "r.urdf")
    data = json.loads(sidecar.read_text())
    closures = read_closures(sidecar)
    assert [c.link1 for c in closures] == [f"leg{i}_link3" for i in range(1, 7)]
    for c, leg, P in zip(closures, h.legs, h.platform_points, strict=True):
        np.testing.assert_array_equal(c.point1, leg.tip)
        np.testing.assert_array_equal(c.point2, P)
    assert data["actuated_joints"] == [f"leg{i}_q1" for i in range(1, 7)]
    terms = data[JOINT_TERMS_KEY]
    assert len(terms) == 18
    crank = h.legs[0].joints[0].dynamics
    t = terms["leg1_q1"]
    assert t["armature"] == crank.total_armature and t["gear_ratio"] == crank.gear_ratio
    assert t["rotor_inertia"] == crank.rotor_inertia and t["own_armature"] == crank.armature
    assert t["stiffness"] == crank.stiffness and t["rest_position"] == crank.rest_position
    assert t["actuated"] and not terms["leg1_q2"]["actuated"]
    assert t["lower"] is None and t["upper"] is None  # unbounded: null, not the URDF's 1e9
    assert parse_joint_terms(data)["leg3_q2"]["viscous"] == h.legs[2].joints[1].dynamics.viscous


def test_malformed_joint_terms_are_refused():
    with pytest.raises(FileFormatError, match="leg1_q1"):
        parse_joint_terms({JOINT_TERMS_KEY: {"leg1_q1": {"armature": "x"}}})
    with pytest.raises(FileFormatError, match="object"):
        parse_joint_terms({JOINT_TERMS_KEY: [1, 2]})
    assert parse_joint_terms({"closures": []}) == {}


# --- MJCF -----------------------------------------------------------------------------------

try:
    import mujoco
except ImportError:  # MuJoCo is optional: the URDF tests above run without it
    mujoco = None
needs_mujoco = pytest.mark.skipif(mujoco is None, reason="MuJoCo is optional: pip install mujoco")


def _mj(h: GeneralHexapod):
    m = mujoco.MjModel.from_xml_string(mjcf_string(h))
    return m, mujoco.MjData(m)


@needs_mujoco
@pytest.mark.parametrize("name", list(PRESETS))
def test_mjcf_structure(name):
    h = robot(name)
    m, data = _mj(h)
    assert (m.nq, m.nv, m.nu, m.neq) == (25, 24, 6, 6)
    np.testing.assert_array_equal(m.opt.gravity, h.gravity)
    hinge, slide = mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE
    for i, leg in enumerate(h.legs, start=1):
        for j, joint in enumerate(leg.joints, start=1):
            jnt = m.joint(f"leg{i}_q{j}")
            assert jnt.type[0] == (hinge if joint.revolute else slide)
            d = joint.dynamics
            assert m.dof_armature[jnt.dofadr[0]] == pytest.approx(d.total_armature, rel=1e-15)
            assert m.dof_damping[jnt.dofadr[0]] == pytest.approx(d.viscous + d.damping, rel=1e-15)
            assert m.dof_frictionloss[jnt.dofadr[0]] == d.coulomb
            assert m.jnt_stiffness[jnt.id] == d.stiffness
            bounded = np.isfinite(joint.lower) and np.isfinite(joint.upper)
            assert bool(m.jnt_limited[jnt.id]) == bounded
            if bounded:
                np.testing.assert_array_equal(m.jnt_range[jnt.id], [joint.lower, joint.upper])
        assert m.actuator(f"leg{i}_motor").trnid[0] == m.joint(f"leg{i}_q{leg.actuated}").id
        np.testing.assert_array_equal(m.actuator(f"leg{i}_motor").gear[:1], [1.0])
    np.testing.assert_array_equal(m.eq_solref, np.tile(LOOP_SOLREF, (6, 1)))
    np.testing.assert_array_equal(m.eq_solimp, np.tile(LOOP_SOLIMP, (6, 1)))
    # the home keyframe closes the loops
    mujoco.mj_resetDataKeyframe(m, data, m.key("home").id)
    mujoco.mj_forward(m, data)
    for i in range(1, 7):
        gap = data.site(f"leg{i}_tip").xpos - data.site(f"platform_p{i}").xpos
        assert np.abs(gap).max() < 1e-12


def set_state(m, data, h: GeneralHexapod, T: np.ndarray, V: np.ndarray) -> np.ndarray:
    """A consistent state: qpos from the inverse geometry, the free joint's velocity ``[v
    in F0, w in Fp]``, the leg rates from MuJoCo's site Jacobians (``Jc qvel = 0``).
    Returns ``Jc`` (18, nv)."""
    return mujoco_set_loop_state(m, data, mujoco_qpos(h, T), T, V)


def mujoco_kkt_inverse_dynamics(m, data, h: GeneralHexapod, T, V, A) -> np.ndarray:
    """The actuated efforts from MuJoCo's M, qfrc_bias, qfrc_passive and loop Jacobians,
    the loops as hard constraints:
    ``M qacc + bias - passive = S^T Gamma + Jc^T lambda``, ``Jc qacc + Jdot qvel = 0``,
    the platform's qacc given, the leg accelerations, Gamma and lambda unknown."""
    Jc = set_state(m, data, h, T, V)
    mujoco.mj_forward(m, data)
    loops = data.efc_type == mujoco.mjtConstraint.mjCNSTR_EQUALITY
    efc_J = np.asarray(data.efc_J).reshape(data.nefc, m.nv)[loops]
    np.testing.assert_allclose(efc_J, Jc, rtol=0, atol=1e-14 * np.abs(Jc).max())
    nv = m.nv
    M = np.zeros((nv, nv))
    mujoco.mj_fullM(m, data, M)
    drift = np.zeros(18)
    jac = np.zeros((3, nv))
    for k in range(6):
        acc = []
        for site in (f"leg{k + 1}_tip", f"platform_p{k + 1}"):
            sid = m.site(site).id
            mujoco.mj_jacDot(m, data, jac, None, data.site_xpos[sid], m.site_bodyid[sid])
            acc.append(jac @ data.qvel)
        drift[3 * k : 3 * k + 3] = acc[0] - acc[1]
    ff = m.joint("platform_joint").dofadr[0]
    F, L = np.arange(ff, ff + 6), mujoco_leg_dofs(m)
    a_F = np.r_[A[:3], T[:3, :3].T @ A[3:]]
    S = np.zeros((6, nv))
    for i, leg in enumerate(h.legs):
        S[i, m.joint(f"leg{i + 1}_q{leg.actuated}").dofadr[0]] = 1.0
    K = np.zeros((42, 42))
    K[:24, :18], K[:24, 18:24], K[:24, 24:] = M[:, L], -S.T, -Jc.T
    K[24:, :18] = Jc[:, L]
    rhs = np.r_[-M[:, F] @ a_F - data.qfrc_bias + data.qfrc_passive, -Jc[:, F] @ a_F - drift]
    return np.linalg.solve(K, rhs)[18:24]


@needs_mujoco
@pytest.mark.parametrize("name", ROBOTS)
def test_mujoco_kkt_inverse_dynamics(name):
    """MuJoCo's model (armature, damping, springs) in a hard-constraint KKT solve equals
    the closure layer's inverse dynamics to 1e-9 (Coulomb set to 0: module docstring)."""
    h = without_coulomb(robot(name))
    m, data = _mj(h)
    T, V, A, _ = states(name, 5, seed=2)
    expected = GeneralDynamics(h).inverse_dynamics(T, V, A)
    for n in range(len(T)):
        got = mujoco_kkt_inverse_dynamics(m, data, h, T[n], V[n], A[n])
        assert rel(got, expected[n]) < 1e-9, f"{name} state {n}: {rel(got, expected[n]):.2e}"


@needs_mujoco
def test_massless_links_are_merged_exactly(tmp_path):
    """A massless crank and U-joint cross (links 1, 2) get no body: their joints ride on
    the rod's body with MuJoCo's sequential joint motion; the dynamics stay exact. The
    reference is Pinocchio's tree from the URDF (which takes massless links)."""
    h = without_coulomb(robot("random-custom-0"))
    inertia = np.array(h.leg_inertia)
    inertia[:, 1] = 0.0
    inertia[::2, 0] = 0.0
    light = h.replace(leg_inertia=inertia)
    assert mujoco_inertials(light).has_body[:, :2].sum() == 3
    m, data = _mj(light)
    assert m.nbody == 1 + 1 + 6 * 3 - 9 + 1
    T, V, A, Q = states("random-custom-0", 3, seed=4)
    urdf, _ = write_urdf(light, tmp_path / "light.urdf")
    solver = GeneralTreeSolver(light, load_tree(urdf))  # type: ignore[arg-type]
    expected = reference_inverse_dynamics(solver, T, V, A, Q)
    for n in range(len(T)):
        got = mujoco_kkt_inverse_dynamics(m, data, light, T[n], V[n], A[n])
        assert rel(got, expected[n]) < 1e-9


#: ``max |A_mujoco - A| <= bound * max(max |A|, |g|)`` for ``mj_forward`` (MuJoCo's soft
#: loops) at consistent states within the joint limits; docs/closures.md has the figures
#: (200 states per robot: worst 1.2e-3 on the presets, 7.4e-3 on random RUS robots).
ACCURACY = {"presets": 2e-3, "random": 1e-2}


@needs_mujoco
@pytest.mark.parametrize("name", ROBOTS)
def test_mj_forward_accelerations_match_direct_model(name):
    h = without_coulomb(robot(name))
    m, data = _mj(h)
    T, V, A, _ = states(name, 5, seed=3)
    gd = GeneralDynamics(h)
    gammas = gd.inverse_dynamics(T, V, A)
    ff = m.joint("platform_joint").dofadr[0]
    worst = 0.0
    for n in range(len(T)):
        set_state(m, data, h, T[n], V[n])
        data.ctrl[:] = gammas[n]
        mujoco.mj_forward(m, data)
        a = data.qacc[ff : ff + 6]
        A_mj = np.r_[a[:3], T[n, :3, :3] @ a[3:]]
        scale = max(np.abs(A[n]).max(), np.linalg.norm(h.gravity))
        worst = max(worst, np.abs(A_mj - A[n]).max() / scale)
    bound = ACCURACY["presets" if name in PRESETS else "random"]
    assert worst <= bound, f"{name}: {worst:.2e}"


# --- Pinocchio's MJCF parser ---------------------------------------------------------------


@needs_mujoco
@pytest.mark.parametrize("name", ["rus", "random-pus-0"])
def test_pinocchio_layout_gives_the_reference_dynamics(name, tmp_path):
    h = robot(name)
    with pytest.raises(ValueError, match="free joint"):
        mujoco.MjModel.from_xml_string(mjcf_string(h, pinocchio_layout=True))
    path = write_mjcf(h, tmp_path / f"{name}.xml", pinocchio_layout=True)
    model, anchors, _ = pin.buildModelAndConstraintsFromMJCF(str(path))
    assert (model.nq, model.nv, len(anchors)) == (25, 24, 6)
    model.gravity.linear = h.gravity
    ids = lambda i, j: model.getJointId(f"leg{i + 1}_q{j + 1}")  # noqa: E731
    q_idx = np.array([[model.idx_qs[ids(i, j)] for j in range(3)] for i in range(6)])
    v_idx = np.array([[model.idx_vs[ids(i, j)] for j in range(3)] for i in range(6)])
    armature = np.array(model.armature)
    for i, leg in enumerate(h.legs):
        for j, joint in enumerate(leg.joints):
            armature[v_idx[i, j]] = joint.dynamics.total_armature
    np.testing.assert_allclose(model.armature, armature, rtol=1e-15, atol=0)
    ff = model.getJointId("platform_joint")
    constraints = [
        pin.RigidConstraintModel(
            pin.ContactType.CONTACT_3D,
            model,
            c.joint1_id,
            c.joint1_placement,
            c.joint2_id,
            c.joint2_placement,
            pin.ReferenceFrame.LOCAL,
        )
        for c in anchors
    ]
    tree = TreeModel(
        model=model,
        constraints=constraints,
        platform_joint=ff,
        leg_q_index=q_idx,
        leg_v_index=v_idx,
        platform_q_index=np.arange(model.idx_qs[ff], model.idx_qs[ff] + 7),
        platform_v_index=np.arange(model.idx_vs[ff], model.idx_vs[ff] + 6),
        actuated=h.actuated,
    )
    T, V, A, Q = states(name, 3, seed=5)
    got = reference_inverse_dynamics(GeneralTreeSolver(h, tree), T, V, A, Q)  # type: ignore[arg-type]
    expected = reference_inverse_dynamics(GeneralTreeSolver(h), T, V, A, Q)
    assert rel(got, expected) < 1e-12


def test_xacro_arguments_of_general_legs_name_the_general_source(tmp_path):
    # the rendering itself is checked against urdf_string in tests/test_xacro.py
    from stewart_pin.formats.xacro import write_xacro_args, xacro_args

    args = xacro_args(rus_preset())
    assert [len(leg["joints"]) for leg in args["legs"]] == [3] * 6
    text = write_xacro_args(rus_preset(), tmp_path / "r.xacro.yaml").read_text()
    assert "stewart_general.urdf.xacro" in text
