"""What the library refuses and follows: MjData of another model, a model changed while
live, wrong argument types, and one chain shared between threads (issue 14, item 8, 9)."""

from __future__ import annotations

import threading

import mujoco
import numpy as np
import pytest

from humanoid_ik import Chain, make_solver, solve
from humanoid_ik.core.models import bundled_model_path
from humanoid_ik.errors import ChainError, HumanoidIKError, SolverError, TargetError

REACHABLE = np.array([0.35, -0.30, 1.15])


def _humanoid_xml() -> str:
    return bundled_model_path().read_text()


def _data_of_renamed_model() -> mujoco.MjData:
    """The humanoid with one joint renamed: same nq, same tree, another model."""
    spec = mujoco.MjSpec.from_file(str(bundled_model_path()))
    spec.joint("right_elbow_joint").name = "elbow_renamed"
    return mujoco.MjData(spec.compile())


def _data_of_line_model(nq: int) -> mujoco.MjData:
    """A chain of ``nq`` hinges in a line: the same nq as the humanoid, another tree."""
    bodies = "".join(
        f'<body pos="0 0 0.1"><joint name="j{i}" axis="0 1 0"/><geom size="0.02"/>'
        for i in range(nq)
    )
    xml = f"<mujoco><worldbody>{bodies}{'</body>' * nq}</worldbody></mujoco>"
    return mujoco.MjData(mujoco.MjModel.from_xml_string(xml))


@pytest.mark.parametrize("make", [_data_of_renamed_model, lambda: _data_of_line_model(16)])
def test_mjdata_of_another_model_with_same_nq_is_refused_and_left_alone(right_arm, make):
    data = make()
    assert data.model.nq == right_arm.model.nq
    data.qpos[:] = 0.123
    with pytest.raises(ChainError, match="another model"):
        solve(right_arm, REACHABLE, "dls", data=data, apply=True)
    with pytest.raises(ChainError, match="another model"):
        right_arm.apply(right_arm.q, data)
    assert np.all(data.qpos == 0.123)


def test_mjdata_of_a_copy_of_the_same_model_is_accepted(right_arm):
    copy = mujoco.MjModel.from_xml_path(str(bundled_model_path()))
    data = mujoco.MjData(copy)
    res = solve(right_arm, REACHABLE, "dls", data=data, apply=True)
    assert res.converged
    np.testing.assert_allclose(data.site_xpos[right_arm.ee_id], REACHABLE, atol=1e-3)


def test_changed_joint_range_on_a_live_model_is_followed_by_every_solve():
    chain = Chain()
    elbow = chain.joint_names.index("right_elbow_joint")
    jid = int(chain.joint_ids[elbow])
    chain.model.jnt_range[jid] = [0.0, 0.3]  # a narrow elbow
    for name in ("dls", "ccd", "pseudoinverse", "closed_form", "lm", "auto", "mink"):
        res = solve(chain, REACHABLE, name, q0=np.zeros(chain.n))
        assert 0.0 - 1e-9 <= res.q[elbow] <= 0.3 + 1e-9, name
        if res.converged:  # a converged answer is within the new range and on target
            pos, _ = chain.fk(res.q)
            assert np.linalg.norm(pos - REACHABLE) < 1e-3
    assert chain.upper[elbow] == pytest.approx(0.3)


def test_closed_form_follows_a_moved_body_on_a_live_model():
    chain = Chain()
    solver = make_solver("closed_form")
    assert solve(chain, REACHABLE, solver).converged  # builds the geometry cache
    forearm = int(
        chain.model.jnt_bodyid[chain.joint_ids[chain.joint_names.index("right_elbow_joint")]]
    )
    chain.model.body_pos[forearm] *= 1.2  # a longer upper arm
    q_true = np.array([0.3, -0.2, 0.1, 1.0, 0.2, 0.1, 0.0])
    target, _ = chain.fk(q_true)  # reachable on the changed model
    res = solve(chain, target, solver, q0=np.zeros(chain.n))
    assert res.converged, res.message
    pos, _ = chain.fk(res.q)
    assert np.linalg.norm(pos - target) < 1e-6


def test_sync_reports_a_change_once_and_refresh_rereads():
    chain = Chain()
    assert chain.sync() is False
    chain.model.jnt_range[chain.joint_ids[0]] = [-0.5, 0.5]
    assert chain.sync() is True
    assert chain.sync() is False
    assert chain.lower[0] == -0.5 and chain.upper[0] == 0.5
    assert chain.within_limits(chain.q)


@pytest.mark.parametrize(
    ("call", "error", "fragment"),
    [
        (lambda c: solve(c, "abc"), TargetError, "target position must be numbers"),
        (lambda c: solve(c, [0.3, None, 1.0]), TargetError, "is not finite"),
        (lambda c: solve(c, REACHABLE, quat="abc"), TargetError, "quaternion must be numbers"),
        (lambda c: solve(c, REACHABLE, q0="x"), TargetError, "joint vector must be 7 real numbers"),
        (lambda c: c.fk([1, "a", 3, 4, 5, 6, 7]), TargetError, "joint vector must be numbers"),
        (lambda c: solve(c, REACHABLE, solver=5), SolverError, "solver must be a solver name"),
        (lambda c: solve(c, REACHABLE, data=object()), ChainError, "expected a mujoco.MjData"),
        (lambda c: Chain(123), ChainError, "model must be a mujoco.MjModel"),
        (lambda c: Chain(site=5), ChainError, "site must be a name"),
        (lambda c: Chain(body=["a"]), ChainError, "body must be a name"),
        (lambda c: Chain(joints=5), ChainError, "joints must be a list"),
    ],
)
def test_wrong_types_raise_errors_of_the_package(right_arm, call, error, fragment):
    with pytest.raises(error, match=fragment) as info:
        call(right_arm)
    assert isinstance(info.value, HumanoidIKError)


def test_a_chain_busy_in_another_thread_is_refused_not_corrupted(right_arm):
    right_arm.claim()  # another thread is in the middle of a solve
    errors: list[BaseException] = []
    t = threading.Thread(target=lambda: _catch(errors, right_arm))
    t.start()
    t.join()
    right_arm.release()
    assert len(errors) == 1 and isinstance(errors[0], ChainError)
    assert "in use by another thread" in str(errors[0])
    assert solve(right_arm, REACHABLE, "ccd").converged  # usable again once released


def _catch(errors: list[BaseException], chain: Chain) -> None:
    try:
        solve(chain, REACHABLE, "ccd")
    except BaseException as exc:  # noqa: BLE001 - handed to the test thread
        errors.append(exc)


def test_threads_with_their_own_chains_match_one_thread():
    rng = np.random.default_rng(7)
    probe = Chain()
    targets = [probe.fk(probe.random_q(rng))[0] for _ in range(40)]

    def run(chain: Chain, out: list) -> None:
        for t in targets:
            res = solve(chain, t, "ccd", q0=np.zeros(chain.n))
            pos, _ = chain.fk(res.q)
            out.append((res.q.copy(), res.position_error, float(np.linalg.norm(pos - t))))

    serial: list = []
    run(Chain(), serial)
    outs: list[list] = [[], []]
    threads = [threading.Thread(target=run, args=(Chain(), outs[i])) for i in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for out in outs:
        assert len(out) == len(serial)
        for (q, err, fk_err), (q1, err1, _) in zip(out, serial, strict=True):
            np.testing.assert_array_equal(q, q1)
            assert err == err1
            assert abs(err - fk_err) < 1e-9  # the reported error is that of its own q


def test_mink_rebuilds_its_problem_after_the_model_changed():
    chain = Chain()
    solver = make_solver("mink")
    assert solve(chain, REACHABLE, solver).converged  # builds and caches the QP
    elbow = chain.joint_names.index("right_elbow_joint")
    chain.model.jnt_range[chain.joint_ids[elbow]] = [0.0, 0.3]
    res = solve(chain, REACHABLE, solver, q0=np.zeros(chain.n))
    assert 0.0 <= res.q[elbow] <= 0.3 + 1e-9
    assert chain.version == 1
