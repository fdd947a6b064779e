"""`choreo identify` on the emulated robot whose servos are the physics, with hidden truths.

Prints:
1. a whole robot identified (default arm6; `--robot hexapod18` is identified on a stand): wall
   time per joint, bus time per joint, position reads per second, and the total;
2. a recovery table: for each servo model (arm6's LX-16A elbow, hexapod18's LX-224HV femur and
   tonypi's LX-824HV left knee, the walkers on a stand), `--truths` random truths (hidden in a truth
   file), each figure's truth against its fit, whether it is within the goal (±15 %, dead band
   and backlash within 0.1°), and the held-out median and p95 error with the assumed figures and
   with the fitted ones;
3. walk travel (`--walk`): hexapod18's walk_forward played on the emulated robot with hidden
   random servos (one per joint type), one leg identified on the stand and its fitted figures
   applied to every leg, against the preview's prediction with the assumed, the fitted and the
   true figures (the goal: the fitted within 3 %).

    python benchmarks/bench_identify.py [--robot arm6] [--truths 5] [--skip-robot] [--skip-truths]
        [--walk] [--cases hexapod18:lf_coxa] [--neighbours stiff|no-play]

`--neighbours` gives the joints next to the identified one (robot order) their assumed figures
with no gear play and dead band (`no-play`) or a 200 N·m/rad gain and 20 N·m stall (`stiff`): what
of a joint's misfit comes from its neighbours (docs/servo-models.md, "A joint's neighbours,
read and replayed").
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml

from choreo.bus.servo_bus import ServoBus
from choreo.bus.servo_models import servo_model
from choreo.bus.settings import BusSettings
from choreo.identify import JointResult, identify
from choreo.identify.fit import assumed_figures
from choreo.preview.actuator import actuator_params
from choreo.robot.robot_file import load_robot
from choreo.robot.types import Robot

CASES = (("arm6", "elbow"), ("hexapod18", "lf_femur"), ("tonypi", "left_knee"))
ABSOLUTE = {"deadband_deg": 0.1, "backlash_deg": 0.1}  # goal: within this many degrees
RELATIVE = 0.15  # goal for the rest: within 15 %
NEIGHBOURS = {
    "no-play": {"backlash_deg": 0.0, "deadband_deg": 0.0},
    "stiff": {"kp_nm_rad": 200.0, "stall_torque_nm": 20.0},
}
SHOWN = (
    ("deadband_deg", "dead band °", 1),
    ("backlash_deg", "backlash °", 1),
    ("no_load_speed_deg_s", "speed °/s", 1),
    ("kp_nm_rad", "gain N·m/rad", 1),
    ("stall_torque_nm", "stall N·m", 1),
    ("friction_nm", "friction N·m", 1),
    ("response_delay_s", "delay ms", 1000),
)


def port(robot: str, truth: Path | None = None, *, on_stand: bool = True) -> str:
    stand = "&stand=1" if on_stand and load_robot(robot).free_floating else ""
    return f"sim://?physics={robot}{stand}" + (f"&truth={truth}" if truth else "")


def random_truth(rng: np.random.Generator, model_name: str) -> dict[str, float]:
    model = servo_model(model_name)
    return {
        "deadband_deg": round(float(rng.uniform(0.1, 0.8)), 3),
        "backlash_deg": round(float(rng.uniform(0.2, 1.5)), 3),
        "no_load_speed_deg_s": round(model.no_load_speed_deg_s * float(rng.uniform(0.75, 1.1)), 1),
        "kp_nm_rad": round(model.kp_nm_rad * float(rng.uniform(0.6, 1.3)), 2),
        "stall_torque_nm": round(model.stall_torque_nm * float(rng.uniform(0.7, 1.1)), 3),
        "friction_nm": round(model.stall_torque_nm * float(rng.uniform(0.005, 0.04)), 4),
        "response_delay_s": round(float(rng.uniform(0.002, 0.02)), 4),
    }


def neighbour_truths(robot: Robot, joint: str, kind: str | None) -> dict[str, dict[str, float]]:
    """The joints next to ``joint`` with their assumed figures changed as ``kind`` says."""
    if kind is None:
        return {}
    j = robot.joint_names.index(joint)
    params = actuator_params(robot)
    truths = {}
    for i in (j - 1, j + 1):
        if 0 <= i < len(robot.joints):
            figures = {k: v for k, v in assumed_figures(params[i]).items() if k != "offset_deg"}
            truths[robot.joint_names[i]] = figures | NEIGHBOURS[kind]
    return truths


def within_goal(name: str, truth: float, fit: float) -> bool:
    if name in ABSOLUTE:
        return abs(fit - truth) <= ABSOLUTE[name]
    return abs(fit - truth) <= RELATIVE * abs(truth)


def identified_on_hidden(
    robot: Robot, joint: str, truth: dict[str, float], neighbours: str | None
) -> JointResult:
    """``joint`` identified on the emulated ``robot`` whose servo there has ``truth`` (hidden in
    a truth file), its neighbours changed as ``neighbours`` says."""
    with tempfile.TemporaryDirectory() as folder:
        truth_file = Path(folder) / "truth.yaml"
        hidden = {joint: truth, **neighbour_truths(robot, joint, neighbours)}
        truth_file.write_text(yaml.safe_dump({"joints": hidden}))
        with ServoBus.from_settings(BusSettings(port=port(robot.name, truth_file))) as bus:
            report = identify(robot, bus, Path(folder) / "fit.yaml", joints=[joint])
    (result,) = report.identified
    return result


def whole_robot(robot_name: str) -> None:
    robot = load_robot(robot_name, with_figures=False)
    print(f"== {robot_name}: every joint identified on {port(robot_name)}")
    times: list[float] = []
    start = last = time.monotonic()
    last_cpu = time.process_time()

    def on_joint(result: JointResult) -> None:
        nonlocal last, last_cpu
        now, cpu = time.monotonic(), time.process_time()
        times.append(now - last)
        cpu_s, last, last_cpu = cpu - last_cpu, now, cpu
        v = result.validation
        print(
            f"  {result.joint:12s} {times[-1]:6.1f} s wall ({cpu_s:5.1f} s CPU)  "
            f"{result.bus_s:5.1f} s bus  "
            f"{result.reads_per_s:5.0f} reads/s ({result.own_reads_per_s:3.0f} own)  "
            f"held-out median {v.default_median_deg:.2f}° -> "
            f"{v.fitted_median_deg:.2f}°",
            flush=True,
        )

    with tempfile.TemporaryDirectory() as folder:
        with ServoBus.from_settings(BusSettings(port=port(robot_name))) as bus:
            identify(robot, bus, Path(folder) / "figures.yaml", on_joint=on_joint)
    total = time.monotonic() - start
    print(
        f"  {len(times)} joints in {total:.0f} s wall ({total / 60:.1f} min; "
        f"{statistics.mean(times):.1f} s per joint)"
    )


def recovery(
    truths: int,
    models: list[str] | None = None,
    cases: tuple[tuple[str, str], ...] = CASES,
    neighbours: str | None = None,
) -> None:
    print(
        f"== recovery: {truths} random truths per servo model (goal ±15 %, 0.1° for dead band "
        "and backlash)"
    )
    rng = np.random.default_rng(2026)
    header = "  model     " + "".join(f"{label:>22s}" for _, label, _ in SHOWN)
    hits: dict[str, list[bool]] = {name: [] for name, _, _ in SHOWN}
    before, after = [], []
    for robot_name, joint in cases:
        robot = load_robot(robot_name, with_figures=False)
        model = robot.joint(joint).servo_model
        if models and model not in models:
            continue
        print(f"-- {model} ({robot_name} {joint})")
        print(header + "   held-out median/p95 assumed -> fitted   neighbours moved")
        case_hits: dict[str, list[bool]] = {name: [] for name, _, _ in SHOWN}
        for _ in range(truths):
            truth = random_truth(rng, model)
            result = identified_on_hidden(robot, joint, truth, neighbours)
            cells = []
            for name, _, scale in SHOWN:
                ok = within_goal(name, truth[name], result.figures[name])
                hits[name].append(ok)
                case_hits[name].append(ok)
                cells.append(
                    f"{truth[name] * scale:9.3g} -> {result.figures[name] * scale:7.3g}"
                    f"{' ' if ok else '*'}"
                )
            v = result.validation
            before.append(v.default_median_deg)
            after.append(v.fitted_median_deg)
            print(
                f"  {model:10s}" + "".join(f"{c:>22s}" for c in cells) + f"   "
                f"{v.default_median_deg:.2f}/{v.default_p95_deg:.2f} -> "
                f"{v.fitted_median_deg:.2f}/{v.fitted_p95_deg:.2f}   "
                + ", ".join(f"{n} {d:.1f}°" for n, d in result.neighbours_moved_deg.items()),
                flush=True,
            )
        print(
            f"  {joint} within the goal: "
            + ", ".join(f"{label} {sum(case_hits[n])}/{len(case_hits[n])}" for n, label, _ in SHOWN)
        )
    print("  within the goal (* marks a miss above):")
    for name, label, _ in SHOWN:
        print(f"    {label:14s} {sum(hits[name])}/{len(hits[name])}")
    print("    offset          not fitted without --drop (a position read cannot see it)")
    print(
        f"  held-out median error: assumed {statistics.median(before):.2f}° -> fitted "
        f"{statistics.median(after):.2f}° (median over truths); fitted <= 0.5°: "
        f"{sum(a <= 0.5 for a in after)}/{len(after)}; at least 50 % below assumed: "
        f"{sum(a <= 0.5 * b for a, b in zip(after, before))}/{len(after)}"
    )


def walk_travel() -> None:
    """walk_forward on the emulated hexapod with hidden servos, against the preview's prediction
    with the assumed, the fitted and the true figures.

    The fitted figures come from identifying one leg (lf_coxa, lf_femur, lf_tibia, on the stand)
    and applying each to the same joint of every leg: identifying all 18 joints takes
    too long on a loaded machine. So the hidden truth is one random servo per joint type (every
    coxa alike, every femur alike, every tibia alike: one batch of the same LX-224HV per role),
    which that leg can find; a robot whose 18 servos all differ needs all 18 identified."""
    from choreo.play.play_motion import play_motion
    from choreo.preview.pipeline import simulate_motion
    from choreo.preview.sim import SimSettings

    motion = "motions/hexapod18/walk_forward.yaml"
    robot = load_robot("hexapod18", with_figures=False)
    rng = np.random.default_rng(7)
    roles = ("coxa", "femur", "tibia")
    by_role = {role: random_truth(rng, robot.joint(f"lf_{role}").servo_model) for role in roles}
    truth = {j.name: by_role[j.name.split("_")[1]] for j in robot.joints}
    print(
        "== walk travel: hexapod18 walk_forward, servos with hidden random figures (one per "
        "joint type), one leg identified"
    )
    with tempfile.TemporaryDirectory() as folder:
        truth_file = Path(folder) / "truth.yaml"
        truth_file.write_text(yaml.safe_dump({"joints": truth}))
        start_s, start_cpu = time.monotonic(), time.process_time()
        with ServoBus.from_settings(BusSettings(port=port("hexapod18", truth_file))) as bus:
            report = identify(
                robot, bus, Path(folder) / "fit.yaml", joints=[f"lf_{r}" for r in roles]
            )
        print(
            f"  one leg identified in {time.monotonic() - start_s:.0f} s wall "
            f"({time.process_time() - start_cpu:.0f} s CPU)"
        )
        fitted_by_role = {r.joint.split("_")[1]: r.figures for r in report.identified}
        fitted = {j.name: fitted_by_role[j.name.split("_")[1]] for j in robot.joints}
        for role in roles:
            true, fit = by_role[role], fitted_by_role[role]
            cells = [
                f"{label} {true[name] * scale:.3g}->{fit[name] * scale:.3g}"
                for name, label, scale in SHOWN
            ]
            print(f"  {role:6s} truth->fit: " + ", ".join(cells))
        walking = port("hexapod18", truth_file, on_stand=False)
        with ServoBus.from_settings(BusSettings(port=walking)) as bus:
            twin = bus.emulator.physics  # type: ignore[union-attr]
            start = twin.body_position_m(bus.clock.now())
            play_motion(motion, bus, on_note=lambda note: None)
            end = twin.body_position_m(bus.clock.now() + 0.5)  # settled
            real_mm = float(np.linalg.norm(end[:2] - start[:2])) * 1000
    for name, overrides in (
        ("assumed figures", None),
        ("fitted figures", fitted),
        ("true figures", truth),
    ):
        travel = simulate_motion(motion, SimSettings(actuator_overrides=overrides)).travel
        predicted = travel.displacement_mm if travel else float("nan")
        print(
            f"  preview with the {name:15s} {predicted:7.1f} mm   emulated robot {real_mm:7.1f} mm"
            f"   {100 * (predicted - real_mm) / real_mm:+6.1f} %  (goal: fitted within 3 %)",
            flush=True,
        )


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robot", default="arm6")
    parser.add_argument("--truths", type=int, default=5)
    parser.add_argument("--models", nargs="+", help="only these servo models' cases")
    parser.add_argument(
        "--cases",
        nargs="+",
        metavar="ROBOT:JOINT",
        help="the recovery table's joints instead of the three above (e.g. hexapod18:lf_coxa)",
    )
    parser.add_argument("--neighbours", choices=sorted(NEIGHBOURS))
    parser.add_argument("--skip-robot", action="store_true")
    parser.add_argument("--skip-truths", action="store_true")
    parser.add_argument("--walk", action="store_true")
    args = parser.parse_args()
    if args.walk:
        walk_travel()
    if not args.skip_robot:
        whole_robot(args.robot)
    if not args.skip_truths:
        cases = tuple(tuple(c.split(":", 1)) for c in args.cases) if args.cases else CASES
        recovery(args.truths, args.models, cases, args.neighbours)  # type: ignore[arg-type]
    return 0


if __name__ == "__main__":
    sys.exit(main())
