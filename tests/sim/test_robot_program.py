"""Robot programs out (``musclecell run --trajectory``): the arms' planned and executed joint
trajectories, tool poses and wrenches as MCAP of ROS 2 messages or as CSV, read back by the
``mcap`` reader and by ``rosbags``; the tool path replayed from the joint states, and again
when the program's commands are played open-loop through the servos; the limits report beside
them."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import mujoco
import numpy as np
import pytest
from mcap.reader import make_reader
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore

from cell.cli import main
from cell.errors import MissingTopicError, RobotLogError, ScenarioError
from cell.robotlog.program import read_program
from cell.sim.assembly import build_scene
from cell.sim.episode import Episode
from cell.sim.programreplay import play_program
from cell.sim.scenario import load_scenario
from cell.sim.trajectory import EpisodeTrajectory, TrajectorySampler
from cell.sim.trajectorylimits import limits_report
from tests.paths import PROJECT_ROOT
from tests.refusals import refused

ARMS = ("knife_arm", "pull_arm", "camera_arm")
TOPICS = {*(f"/{arm}/joint_states" for arm in ARMS),
          *(f"/{arm}/joint_trajectory" for arm in ARMS), "/knife/wrench", "/gripper/wrench",
          "/tf"}


def _run(scenario: Path, out: Path) -> Path:
    assert main(["run", str(scenario), "--trajectory", str(out), "--quiet"]) == 0
    return out


@pytest.fixture(scope="module")
def short(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A short episode's trajectory written as MCAP and as CSV (two runs of one seed)."""
    folder = tmp_path_factory.mktemp("trajectory")
    scenario = folder / "short.toml"
    scenario.write_text('[scenario]\nname = "short"\nend_s = 0.4\n[tissue]\ncell_size_m = '
                        "0.05\nlength_m = 0.3\n[perception]\nenabled = false\n")
    _run(scenario, folder / "program.mcap")
    _run(scenario, folder / "program.csv")
    return folder


def _mcap_messages(path: Path) -> dict[str, list]:
    """Every message of the file by topic, read by ``mcap`` and decoded by ``rosbags``."""
    typestore = get_typestore(Stores.ROS2_HUMBLE)
    out: dict[str, list] = {}
    with path.open("rb") as stream:
        for schema, channel, message in make_reader(stream).iter_messages(log_time_order=True):
            assert (schema.encoding, channel.message_encoding) == ("ros2msg", "cdr")
            out.setdefault(channel.topic, []).append(
                typestore.deserialize_cdr(message.data, schema.name))
    return out


def test_the_mcap_opens_with_the_mcap_reader_and_with_rosbags(short: Path) -> None:
    messages = _mcap_messages(short / "program.mcap")
    assert set(messages) == TOPICS
    steps = len(messages["/tf"])
    assert steps == 20  # 0.4 s at the control rate of 50 Hz
    assert all(len(messages[f"/{arm}/joint_states"]) == steps for arm in ARMS)
    plan = messages["/knife_arm/joint_trajectory"]
    assert len(plan) == 1 and len(plan[0].points) == steps
    assert plan[0].joint_names == [f"knife_arm/joint{k}" for k in range(1, 7)]
    with AnyReader([short / "program.mcap"]) as reader:
        assert set(reader.topics) == TOPICS
        states = [reader.deserialize(raw, connection.msgtype) for connection, _, raw
                  in reader.messages(connections=[c for c in reader.connections
                                                  if c.topic == "/pull_arm/joint_states"])]
    assert len(states) == steps and states[0].name[0] == "pull_arm/joint1"
    assert {m.header.frame_id for m in messages["/knife/wrench"]} == {"knife/ft"}


def test_the_messages_are_serialised_as_rosbags_serialises_them(short: Path) -> None:
    typestore = get_typestore(Stores.ROS2_HUMBLE)
    with (short / "program.mcap").open("rb") as stream:
        for schema, _, message in make_reader(stream).iter_messages():
            decoded = typestore.deserialize_cdr(message.data, schema.name)
            assert bytes(typestore.serialize_cdr(decoded, schema.name)) == message.data


def test_the_schemas_are_rosbags_definitions(short: Path) -> None:
    typestore = get_typestore(Stores.ROS2_HUMBLE)
    with (short / "program.mcap").open("rb") as stream:
        schemas = make_reader(stream).get_summary().schemas.values()
    assert {schema.name for schema in schemas} == {
        "trajectory_msgs/msg/JointTrajectory", "sensor_msgs/msg/JointState",
        "geometry_msgs/msg/WrenchStamped", "tf2_msgs/msg/TFMessage"}
    for schema in schemas:
        assert schema.data.decode() == typestore.generate_msgdef(schema.name, ros_version=2)[0]


def test_the_csv_holds_the_mcap_numbers(short: Path) -> None:
    messages = _mcap_messages(short / "program.mcap")
    table = np.genfromtxt(short / "program.csv", delimiter=",", names=True, deletechars="")
    states = messages["/knife_arm/joint_states"]
    stamps_ns = [m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for m in states]
    assert np.array_equal(np.round(table["time_s"] * 1e9), stamps_ns)  # ROS times are in ns
    for k in range(6):
        joint = f"knife_arm/joint{k + 1}"
        assert np.array_equal(table[f"{joint}.q_rad"], [m.position[k] for m in states])
        assert np.array_equal(table[f"{joint}.qd_rad_s"], [m.velocity[k] for m in states])
        plan = messages["/knife_arm/joint_trajectory"][0].points
        assert np.array_equal(table[f"{joint}.planned_q_rad"], [p.positions[k] for p in plan])
    wrench = messages["/gripper/wrench"]
    assert np.array_equal(table["gripper.force_z_n"], [m.wrench.force.z for m in wrench])
    tips = [next(t for t in m.transforms if t.child_frame_id == "knife/tip")
            for m in messages["/tf"]]
    assert np.array_equal(table["knife/tip.y_m"], [t.transform.translation.y for t in tips])


def _tool_path_error_m(scenario_path: Path, mcap: Path, seed: int | None = None) -> float:
    """The largest distance between the knife tip's logged path and the one the joint states
    of the file give the cell's model (forward kinematics, the arms open-loop), m."""
    scenario = load_scenario(scenario_path)
    model = build_scene(scenario if seed is None else replace(scenario, seed=seed)).model
    data = mujoco.MjData(model)
    messages = _mcap_messages(mcap)
    tip = model.site("knife/tip").id
    errors = []
    for k, frame in enumerate(messages["/tf"]):
        for arm in ARMS:
            state = messages[f"/{arm}/joint_states"][k]
            for name, q in zip(state.name, state.position, strict=True):
                data.qpos[model.joint(name).qposadr[0]] = q
        mujoco.mj_kinematics(model, data)
        logged = next(t.transform.translation for t in frame.transforms
                      if t.child_frame_id == "knife/tip")
        errors.append(np.linalg.norm(data.site_xpos[tip] - [logged.x, logged.y, logged.z]))
    return float(max(errors))


def test_the_joint_states_replayed_give_the_tool_path(short: Path) -> None:
    assert _tool_path_error_m(short / "short.toml", short / "program.mcap") < 0.5e-3


def _played_error_m(scenario_path: Path, program: Path, mcap: Path) -> float:
    """The largest distance between the knife tip's logged path (the MCAP's ``/tf``) and the
    one the program's commands give when played open-loop through the servos, m."""
    played = play_program(load_scenario(scenario_path), read_program(program, ARMS))
    logged = np.array([[t.transform.translation.x, t.transform.translation.y,
                        t.transform.translation.z]
                       for frame in _mcap_messages(mcap)["/tf"] for t in frame.transforms
                       if t.child_frame_id == "knife/tip"])
    return float(np.linalg.norm(played.arms["knife_arm"].tool_position_m - logged,
                                axis=1).max())


@pytest.mark.parametrize("form", ["program.mcap", "program.csv"])
def test_the_program_played_open_loop_gives_the_tool_path(short: Path, form: str) -> None:
    assert _played_error_m(short / "short.toml", short / form, short / "program.mcap") < 0.5e-3


def test_a_program_without_an_arm_is_named(short: Path, tmp_path: Path) -> None:
    with pytest.raises(MissingTopicError, match="/robot_arm/joint_trajectory"):
        read_program(short / "program.mcap", ["robot_arm"])
    with pytest.raises(RobotLogError, match="robot_arm"):
        read_program(short / "program.csv", ["robot_arm"])
    with pytest.raises(ScenarioError, match="no commands for the joints"):
        play_program(load_scenario(short / "short.toml"),
                     read_program(short / "program.csv", ARMS[:2]))


def test_the_limits_report_holds_and_names_each_arm(short: Path) -> None:
    report = json.loads((short / "program.limits.json").read_text())
    assert report["holds"] and report["flags"] == []
    assert set(report["arms"]) == set(ARMS)
    knife = report["arms"]["knife_arm"]
    assert set(knife["clearance"]) == {"pull_arm", "camera_arm", "table", "fixture"}
    assert 0.0 < knife["clearance"]["table"]["clearance_m"] < 1.0
    joint = knife["joints"]["knife_arm/joint1"]
    assert joint["planned_speed_rad_s"] < joint["max_speed_rad_s"]


def _too_fast(trajectory: EpisodeTrajectory, arm: str, joint: int, jump_rad: float
              ) -> EpisodeTrajectory:
    """The plan with one joint sent ``jump_rad`` away in one control step at its middle."""
    arms = dict(trajectory.arms)
    planned = arms[arm].planned_q_rad.copy()
    planned[len(planned) // 2:, joint] += jump_rad
    speed = np.diff(np.vstack([trajectory.start_q_rad[arm], planned]), axis=0)
    arms[arm] = replace(arms[arm], planned_q_rad=planned,
                        planned_qd_rad_s=speed / trajectory.control_dt_s)
    return replace(trajectory, arms=arms)


def test_a_plan_made_too_fast_is_flagged() -> None:
    scenario = load_scenario(PROJECT_ROOT / "scenarios" / "quick.toml")
    scenario = replace(scenario, end_s=0.2, perception=replace(scenario.perception,
                                                               enabled=False))
    episode = Episode(scenario)
    sampler = TrajectorySampler.attach(episode)
    episode.run()
    trajectory = sampler.trajectory()
    assert limits_report(episode.sim.model, episode.sim.data.qpos, trajectory)["holds"]
    # 0.1 rad in one 20 ms step: 5 rad/s, over the Viper's 2.97 rad/s at its first joint.
    fast = limits_report(episode.sim.model, episode.sim.data.qpos,
                         _too_fast(trajectory, "pull_arm", 0, 0.1))
    assert not fast["holds"]
    assert fast["flags"] == ["pull_arm/joint1: planned speed 5 rad/s over its limit "
                             "2.97 rad/s"]
    # An arm rated for accelerations (a scenario's max_accel_rad_s2) is checked against them.
    slow_arm = replace(trajectory.arms["pull_arm"], max_accel_rad_s2=np.full(6, 1e-3))
    rated = replace(trajectory, arms={**trajectory.arms, "pull_arm": slow_arm})
    flags = limits_report(episode.sim.model, episode.sim.data.qpos, rated)["flags"]
    assert flags and all(flag.startswith("pull_arm/joint") and " acceleration " in flag
                         and flag.endswith("over its limit 0.001 rad/s2") for flag in flags)


def test_a_trajectory_of_another_form_is_refused(tmp_path: Path) -> None:
    (tmp_path / "s.toml").write_text("[scenario]\nend_s = 0.1\n")
    message = refused(tmp_path, "run", "s.toml", "--trajectory", "program.bag",
                      words=("--trajectory", ".mcap or .csv"))
    assert "program.bag" in message


@pytest.mark.slow
def test_the_default_episode_program_replays_and_holds(tmp_path: Path) -> None:
    default = PROJECT_ROOT / "scenarios" / "default.toml"
    mcap = _run(default, tmp_path / "default.mcap")
    assert _tool_path_error_m(default, mcap) < 0.5e-3
    assert _played_error_m(default, mcap, mcap) < 0.5e-3
    report = json.loads((tmp_path / "default.limits.json").read_text())
    assert report["holds"], report["flags"]
