"""Pinocchio models (stewart_pin.models.pinocchio_models) and the URDF they come from.

References: Pinocchio's own parser and algorithms on the generated URDF, yourdfpy as a
second, independent URDF reader, and the description's arrays.
"""

from __future__ import annotations

import json

import numpy as np
import pinocchio as pin
import pytest
import yourdfpy
from conftest import get_robot
from helpers import points_in_base, tree_configuration

from stewart_pin import FileFormatError
from stewart_pin.description.inertia import khalil_from_pin_inertia
from stewart_pin.formats.urdf import closures_dict, parse_closures, read_closures, urdf_string
from stewart_pin.models.pinocchio_models import build_tree, load_tree, tree_from_files

LINKS = [f"leg{i}_link{j}" for i in range(1, 7) for j in (1, 2, 3)] + ["platform"]


@pytest.fixture(scope="module", params=["desktop", "random-0", "random-1"])
def robot(request):
    return get_robot(request.param)


# ---------------------------------------------------------------------- the tree
def test_tree_dimensions(robot):
    tree = robot.tree
    model = tree.model
    assert (model.nq, model.nv, model.njoints) == (25, 24, 20)
    assert len(tree.constraints) == 6
    for k, cm in enumerate(tree.constraints):
        assert cm.type == pin.ContactType.CONTACT_3D
        assert cm.reference_frame == pin.ReferenceFrame.LOCAL
        assert cm.name == f"loop{k + 1}"
        assert model.names[cm.joint1_id] == f"leg{k + 1}_q3"
        assert model.names[cm.joint2_id] == "platform_joint"
    ff = model.joints[tree.platform_joint]
    assert ff.shortname() == "JointModelFreeFlyer"
    assert list(tree.platform_v_index) == list(range(ff.idx_v, ff.idx_v + 6))
    for i in range(6):
        for j in range(3):
            jid = model.getJointId(f"leg{i + 1}_q{j + 1}")
            assert tree.leg_q_index[i, j] == model.idx_qs[jid]
            assert tree.leg_v_index[i, j] == model.idx_vs[jid]
    assert model.joints[model.getJointId("leg1_q3")].shortname() == "JointModelPZ"
    assert model.joints[model.getJointId("leg1_q1")].shortname() == "JointModelRZ"


def test_inertias_read_back_from_pinocchio_equal_the_description(robot):
    desc, model = robot.description, robot.tree.model
    for i in range(6):
        for j in range(3):
            jid = model.getJointId(f"leg{i + 1}_q{j + 1}")
            expected = desc.leg_inertia[i, j]
            got = khalil_from_pin_inertia(model.inertias[jid])
            np.testing.assert_allclose(
                got, expected, rtol=0, atol=1e-12 * np.abs(expected).max(), err_msg=f"{i} {j}"
            )
    got = khalil_from_pin_inertia(model.inertias[robot.tree.platform_joint])
    expected = desc.platform_inertia
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12 * np.abs(expected).max())


def test_inertias_read_back_by_yourdfpy(robot, tmp_path):
    # A second reader: URDF mass, centre of mass and inertia about it, converted here by
    # the parallel-axis theorem, give the description's Khalil parameters.
    urdf, _ = robot.write_urdf(tmp_path / "robot.urdf")
    parsed = yourdfpy.URDF.load(str(urdf), load_meshes=False, build_scene_graph=True)
    desc = robot.description
    bodies = dict(
        zip(LINKS, [*desc.leg_inertia.reshape(18, 10), desc.platform_inertia], strict=True)
    )
    for name, expected in bodies.items():
        inertial = parsed.link_map[name].inertial
        m, c, I_c = inertial.mass, inertial.origin[:3, 3], inertial.inertia
        np.testing.assert_array_equal(inertial.origin[:3, :3], np.eye(3))
        I_O = I_c + m * (c @ c * np.eye(3) - np.outer(c, c))
        got = np.r_[I_O[0, 0], I_O[0, 1], I_O[0, 2], I_O[1, 1], I_O[1, 2], I_O[2, 2], m * c, m]
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12 * np.abs(expected).max())


def test_urdf_loads_in_yourdfpy_with_19_links_and_the_base(robot, tmp_path):
    urdf, _ = robot.write_urdf(tmp_path / "robot.urdf")
    parsed = yourdfpy.URDF.load(str(urdf), load_meshes=False, build_scene_graph=True)
    assert parsed.base_link == "base_link"
    assert sorted(parsed.link_map) == sorted(["base_link", *LINKS])
    types = {j.name: j.type for j in parsed.robot.joints}
    assert len(types) == 19
    assert types["platform_joint"] == "floating"
    for i in range(1, 7):
        assert (types[f"leg{i}_q1"], types[f"leg{i}_q2"], types[f"leg{i}_q3"]) == (
            "revolute",
            "revolute",
            "prismatic",
        )
        lim = parsed.joint_map[f"leg{i}_q3"].limit
        assert (lim.lower, lim.upper) == tuple(robot.description.stroke)


def test_yourdfpy_forward_kinematics_puts_the_tips_at_P_i(robot, tmp_path):
    # yourdfpy shares no code with Pinocchio: a second check of the URDF's joint frames.
    urdf, _ = robot.write_urdf(tmp_path / "robot.urdf")
    parsed = yourdfpy.URDF.load(str(urdf), load_meshes=False, build_scene_graph=True)
    for T in robot.sample_poses(3, np.random.default_rng(0)):
        q = robot.inverse_geometry(T)
        parsed.update_cfg({f"leg{i + 1}_q{j + 1}": q[i, j] for i in range(6) for j in range(3)})
        P = points_in_base(robot.description, T)
        for i in range(6):
            tip = parsed.get_transform(f"leg{i + 1}_link3", "base_link")[:3, 3]
            np.testing.assert_allclose(tip, P[i], rtol=0, atol=1e-12)


def test_closure_residual_is_zero_at_inverse_geometry(robot):
    model = robot.tree.model
    data = model.createData()
    for T in robot.sample_poses(4, np.random.default_rng(1)):
        q = tree_configuration(model, T, robot.inverse_geometry(T))
        pin.forwardKinematics(model, data, q)
        for cm in robot.tree.constraints:
            side1 = data.oMi[cm.joint1_id] * cm.joint1_placement
            side2 = data.oMi[cm.joint2_id] * cm.joint2_placement
            np.testing.assert_allclose(side1.translation, side2.translation, rtol=0, atol=1e-12)


def test_closure_residual_is_not_zero_off_the_loop(robot):
    # The same check must fail when the legs do not match the pose (guards the test above).
    model = robot.tree.model
    data = model.createData()
    T = robot.home_pose
    q_legs = robot.inverse_geometry(T)
    q_legs[:, 2] += 1e-3  # [m]
    pin.forwardKinematics(model, data, tree_configuration(model, T, q_legs))
    for cm in robot.tree.constraints:
        side1 = data.oMi[cm.joint1_id] * cm.joint1_placement
        side2 = data.oMi[cm.joint2_id] * cm.joint2_placement
        assert np.linalg.norm(side1.translation - side2.translation) == pytest.approx(1e-3)


def test_gravity_comes_from_the_description(robot):
    g = robot.description.gravity
    np.testing.assert_array_equal(robot.tree.model.gravity.linear, g)
    np.testing.assert_array_equal(robot.tree.model.gravity.angular, np.zeros(3))
    for model in robot.leg_models:
        np.testing.assert_array_equal(model.gravity.linear, g)
    np.testing.assert_array_equal(robot.legs_model[0].gravity.linear, g)


def test_random_robot_gravity_is_not_the_default():
    # guards the gravity test: the random robots tilt gravity
    assert np.abs(get_robot("random-0").description.gravity[:2]).max() > 1e-3


# ---------------------------------------------------------------------- leg models
def test_leg_models(robot):
    assert len(robot.leg_models) == 6
    for i, model in enumerate(robot.leg_models):
        assert (model.nq, model.nv) == (3, 3)
        assert list(model.names)[1:] == [f"leg{i + 1}_q{j}" for j in (1, 2, 3)]
        assert model.existFrame(f"leg{i + 1}_link3")


def test_leg_model_inertias_equal_the_description(robot):
    desc = robot.description
    for i, model in enumerate(robot.leg_models):
        for j in range(3):
            expected = desc.leg_inertia[i, j]
            np.testing.assert_allclose(
                khalil_from_pin_inertia(model.inertias[j + 1]),
                expected,
                rtol=0,
                atol=1e-12 * np.abs(expected).max(),
            )


def test_legs_model_rnea_equals_the_per_leg_rnea(robot):
    legs, v_idx = robot.legs_model
    assert (legs.nq, legs.nv) == (18, 18)
    assert v_idx.shape == (6, 3)
    assert sorted(v_idx.ravel()) == list(range(18))
    data, rng = legs.createData(), np.random.default_rng(2)
    for _ in range(3):
        q, v, a = rng.uniform(-1, 1, (3, 18))
        q[v_idx[:, 1]] += np.pi / 2
        q[v_idx[:, 2]] = robot.description.stroke_mid
        tau = pin.rnea(legs, data, q, v, a)
        for i, model in enumerate(robot.leg_models):
            k = v_idx[i]
            tau_i = pin.rnea(model, model.createData(), q[k], v[k], a[k])
            np.testing.assert_allclose(tau[k], tau_i, rtol=0, atol=1e-12 * np.abs(tau).max())


def test_tree_rnea_of_a_leg_equals_its_leg_model(robot):
    # With the platform at rest, the leg rows of the tree's RNEA are that leg's own RNEA.
    tree = robot.tree
    model, data = tree.model, tree.model.createData()
    rng = np.random.default_rng(3)
    q = tree_configuration(model, robot.home_pose, robot.inverse_geometry(robot.home_pose))
    v, a = rng.uniform(-1, 1, (2, 24))
    v[tree.platform_v_index] = a[tree.platform_v_index] = 0.0
    tau = pin.rnea(model, data, q, v, a)
    for i, leg in enumerate(robot.leg_models):
        qi, vi = tree.leg_q_index[i], tree.leg_v_index[i]
        tau_i = pin.rnea(leg, leg.createData(), q[qi], v[vi], a[vi])
        np.testing.assert_allclose(tau[vi], tau_i, rtol=0, atol=1e-12 * np.abs(tau_i).max())


# ---------------------------------------------------------------------- files
def test_load_tree_from_files_equals_build_tree(robot, tmp_path):
    urdf, sidecar = robot.write_urdf(tmp_path / "robot.urdf")
    assert sidecar.name == "robot.closures.json"
    loaded = load_tree(urdf)  # gravity from the sidecar
    built = robot.tree
    assert list(loaded.model.names) == list(built.model.names)
    np.testing.assert_array_equal(loaded.model.gravity.linear, built.model.gravity.linear)
    for jid in range(built.model.njoints):
        np.testing.assert_array_equal(
            loaded.model.jointPlacements[jid].homogeneous,
            built.model.jointPlacements[jid].homogeneous,
        )
        np.testing.assert_array_equal(
            loaded.model.inertias[jid].toDynamicParameters(),
            built.model.inertias[jid].toDynamicParameters(),
        )
    for a, b in zip(loaded.constraints, built.constraints, strict=True):
        assert (a.name, a.joint1_id, a.joint2_id) == (b.name, b.joint1_id, b.joint2_id)
        np.testing.assert_array_equal(
            a.joint1_placement.homogeneous, b.joint1_placement.homogeneous
        )
        np.testing.assert_array_equal(
            a.joint2_placement.homogeneous, b.joint2_placement.homogeneous
        )
    for key in ("leg_q_index", "leg_v_index", "platform_q_index", "platform_v_index"):
        np.testing.assert_array_equal(getattr(loaded, key), getattr(built, key))


def test_load_tree_gravity_from_sidecar_or_argument(tmp_path):
    robot = get_robot("random-1")  # tilted gravity
    urdf, sidecar = robot.write_urdf(tmp_path / "r.urdf")
    np.testing.assert_array_equal(load_tree(urdf).model.gravity.linear, robot.description.gravity)
    np.testing.assert_array_equal(
        load_tree(urdf, [0, 0, -1.62]).model.gravity.linear, [0, 0, -1.62]
    )
    data = json.loads(sidecar.read_text())
    del data["gravity"]  # a sidecar written by another tool may not record it
    sidecar.write_text(json.dumps(data))
    np.testing.assert_array_equal(load_tree(urdf).model.gravity.linear, [0.0, 0.0, -9.81])
    data["gravity"] = [0.0, "down"]
    sidecar.write_text(json.dumps(data))
    with pytest.raises(FileFormatError, match="gravity"):
        load_tree(urdf)


def test_sidecar_content(paper, tmp_path):
    _, sidecar = paper.write_urdf(tmp_path / "p.urdf")
    closures = read_closures(sidecar)
    assert [c.name for c in closures] == [f"loop{i}" for i in range(1, 7)]
    for i, c in enumerate(closures):
        assert (c.link1, c.link2) == (f"leg{i + 1}_link3", "platform")
        np.testing.assert_array_equal(c.point1, np.zeros(3))
        np.testing.assert_array_equal(c.point2, paper.description.platform_points[i])


def test_missing_files_raise_file_format_error(tmp_path):
    with pytest.raises(FileFormatError, match="cannot read"):
        load_tree(tmp_path / "none.urdf")
    (tmp_path / "x.urdf").write_text(urdf_string(get_robot("desktop").description))
    with pytest.raises(FileFormatError, match="cannot read loop closures"):
        load_tree(tmp_path / "x.urdf")


def _sidecar(**changes):
    d = closures_dict(get_robot("desktop").description)
    d.update(changes)
    return d


@pytest.mark.parametrize(
    ("data", "message"),
    [
        ([], "not a 'stewart-pin/closures' document"),
        (_sidecar(format="other"), "not a 'stewart-pin/closures' document"),
        (_sidecar(version=2), "unsupported version 2"),
        (_sidecar(closures=[]), "'closures' must be a non-empty list"),
        (
            _sidecar(closures=[{"name": "a", "type": "hinge", "link1": "x", "point1": [0, 0, 0]}]),
            "closure 0 has type 'hinge'",
        ),
        (
            _sidecar(closures=[{"name": "a", "type": "point", "link1": "x", "point1": [0, 0, 0]}]),
            "closure 0 is malformed",
        ),
        (
            _sidecar(
                closures=[
                    {
                        "name": "a",
                        "type": "point",
                        "link1": "x",
                        "point1": [0, 0],
                        "link2": "y",
                        "point2": [0, 0, 0],
                    }
                ]
            ),
            "closure 0 points must be 3 finite numbers",
        ),
    ],
)
def test_bad_sidecar_raises_file_format_error(data, message):
    with pytest.raises(FileFormatError, match=message):
        parse_closures(data)


def test_closure_on_an_unknown_link(desktop):
    closures = parse_closures(closures_dict(desktop.description))
    bad = [
        *closures[:5],
        type(closures[5])("loop6", "leg6_link9", np.zeros(3), "platform", np.zeros(3)),
    ]
    with pytest.raises(FileFormatError, match="names an unknown link 'leg6_link9'"):
        tree_from_files(urdf_string(desktop.description), bad, desktop.description.gravity)


def test_unparsable_urdf_raises_file_format_error(desktop):
    closures = parse_closures(closures_dict(desktop.description))
    with pytest.raises(FileFormatError, match="Pinocchio cannot parse the URDF"):
        tree_from_files("<robot name='x'><link name='a'>", closures, desktop.description.gravity)


def test_build_tree_is_deterministic(desktop):
    a, b = build_tree(desktop.description), build_tree(desktop.description)
    for jid in range(a.model.njoints):
        np.testing.assert_array_equal(
            a.model.inertias[jid].toDynamicParameters(),
            b.model.inertias[jid].toDynamicParameters(),
        )


def test_docs_sidecar_excerpt_parses_and_matches_the_desktop_preset():
    import json
    import re
    from pathlib import Path

    text = (Path(__file__).parents[1] / "docs" / "closures.md").read_text()
    excerpt = json.loads(re.search(r"```json\n(.*?)```", text, re.S).group(1))
    full = closures_dict(get_robot("desktop").description)
    assert set(excerpt) == set(full)
    assert excerpt["closures"][0] == full["closures"][0]
    assert excerpt["actuated_joints"] == full["actuated_joints"]
    assert len(parse_closures(excerpt)) == 1


def test_leg_models_from_one_parse_equal_each_built_alone():
    from stewart_pin.formats.urdf import PLATFORM_JOINT, leg_joint
    from stewart_pin.models.pinocchio_models import build_leg_models

    desc = get_robot("random-1").description
    for i, model in enumerate(build_leg_models(desc)):
        # Leg i alone: a fresh parse of the URDF (build_tree), every other joint locked.
        tree = build_tree(desc).model
        others = [leg_joint(k + 1, j) for k in range(6) if k != i for j in (1, 2, 3)]
        locked = [tree.getJointId(name) for name in (PLATFORM_JOINT, *others)]
        alone = pin.buildReducedModel(tree, locked, pin.neutral(tree))
        assert list(model.names) == list(alone.names)
        for jid in range(1, model.njoints):
            np.testing.assert_array_equal(
                model.inertias[jid].toDynamicParameters(),
                alone.inertias[jid].toDynamicParameters(),
            )
            np.testing.assert_array_equal(
                model.jointPlacements[jid].homogeneous, alone.jointPlacements[jid].homogeneous
            )
