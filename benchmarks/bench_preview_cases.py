"""How well the preview judges: false negatives and false positives over hand-built cases.

Each case is a motion with what a roboticist expects from it on the real robot, argued in its
comment: "fail" (it would go wrong: at least one error), "warn" (it works, with little margin:
warnings, no error) or "pass" (nothing to report). The preview's verdict is the worst severity
it reports. A false negative is a verdict milder than expected, a false positive a harsher one.
Variants of shipped motions are written to a temporary folder.

Run: python benchmarks/bench_preview_cases.py [--only SUBSTRING]
"""

from __future__ import annotations

import argparse
import dataclasses
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from choreo.motion.motion_file import Motion, load_motion
from choreo.preview import Severity, run_checks, simulate_motion

REPO = Path(__file__).resolve().parents[1]
MOTIONS = REPO / "motions"
DATA = REPO / "tests" / "data" / "preview" / "motions"
SPATIAL = REPO / "tests" / "data" / "spatial"
ORDER = {"pass": 0, "warn": 1, "fail": 2}


@dataclass(frozen=True)
class Case:
    name: str
    expected: str  # fail | warn | pass
    load: Callable[[Path], Motion]
    start_pose: str | None = None  # None: home; "first": at rest in the first keyframe


def file(path: Path) -> Callable[[Path], Motion]:
    return lambda _folder: load_motion(path)


def variant(path: Path, *edits: tuple[str, str], extra: str = "") -> Callable[[Path], Motion]:
    """``path`` with text replaced (each edit must apply), its robot named by path."""

    def load(folder: Path) -> Motion:
        text = path.read_text()
        for old, new in edits:
            assert old in text, (path, old)
            text = text.replace(old, new)
        robot = load_motion(path).robot.path.as_posix()
        lines = [
            f"robot: {robot}" if line.startswith("robot:") else line for line in text.splitlines()
        ]
        out = folder / f"{path.stem}_{abs(hash((edits, extra)))}.yaml"
        out.write_text("\n".join(lines) + "\n" + extra)
        return load_motion(out)

    return load


def repeated(path: Path, times: int) -> Callable[[Path], Motion]:
    def load(folder: Path) -> Motion:
        robot = load_motion(path).robot.path.as_posix()
        out = folder / f"{path.stem}_x{times}.yaml"
        out.write_text(f"robot: {robot}\nrepeat: {times}\nkeyframes:\n  - include: {path}\n")
        return load_motion(out)

    return load


def with_block(path: Path, **fields) -> Callable[[Path], Motion]:
    def load(_folder: Path) -> Motion:
        motion = load_motion(path)
        return dataclasses.replace(motion, props=(dataclasses.replace(motion.props[0], **fields),))

    return load


PICK = MOTIONS / "arm6" / "pick_and_place.yaml"
HEX = MOTIONS / "hexapod18"

CASES = [
    # --- should fail ----------------------------------------------------------------------------
    # the forearm folded down over the base plate: two links that are not neighbours collide
    Case("arm3 forearm into its base", "fail", file(DATA / "collide.yaml")),
    # leaning out past the base plate and down puts the forearm on the floor
    Case("arm3 forearm on the floor", "fail", file(DATA / "floor.yaml")),
    # a 1 kg payload lifted out sideways needs ~2 N·m, more than the 1.67 N·m stall torque
    Case("arm3 1 kg payload lifted to 90°", "fail", file(DATA / "too_heavy.yaml")),
    # three left femurs lifted together: the hexapod loses its left support and tips over
    Case("hexapod left legs up", "fail", file(DATA / "hexapod_tip.yaml")),
    # four corner feet lifted 15 mm: two middle feet are a line, not a polygon; it pitches over
    # onto two lifted legs (a stumble: a few degrees, no torso on the floor)
    Case("hexapod four legs up 15 mm", "fail", file(DATA / "four_legs_up.yaml")),
    # front and middle feet raised 15 mm by sites: the rear two are all it leaves down; it
    # tips forward onto the raised legs (read before as a tilt over the corner feet)
    Case("hexapod front and middle legs up", "fail", file(DATA / "front_legs_up.yaml")),
    # end: lying_front declared, but bending at the hips with straight legs: it topples and
    # its torso hits the floor at ~1.5 m/s
    Case("tonypi topples onto its face", "fail", file(DATA / "topple_declared.yaml")),
    # stand_up backwards without end: lying: the torso goes down onto the floor
    Case("hexapod lies down, undeclared", "fail", file(DATA / "lie_down.yaml")),
    # a 1 kg payload held at 45°: the shoulder stalls and the tip sinks ~58 mm from its target
    Case("arm3 payload held at 45°", "fail", file(DATA / "reach_collapses.yaml")),
    # the block's place target 10 cm beyond where the arm sets it down: it cannot end there
    Case(
        "pick_and_place, target 10 cm off",
        "fail",
        with_block(PICK, place_at_m=(0.2028, -0.1226, 0.0)),
    ),
    # the gripper closes only to 21°, where the pads barely meet the 30 mm block: no squeeze,
    # no friction to lift it; it stays where it was, 245 mm from its target
    Case(
        "pick_and_place, grip too loose",
        "fail",
        variant(PICK, ("gripper: 16}", "gripper: 21}")),
    ),
    # a 100 g block squeezed half a degree past contact: lifted 16 mm, it slips out (dropped)
    Case(
        "pick_and_place, 100 g block, lightest grip",
        "fail",
        variant(PICK, ("gripper: 16}", "gripper: 19.5}"), ("mass_kg: 0.02", "mass_kg: 0.1")),
    ),
    # a 780 g block in the 19° grip: half the friction its weight needs, it never leaves the
    # table
    Case(
        "pick_and_place, 780 g block, light grip",
        "fail",
        variant(PICK, ("gripper: 16}", "gripper: 19}"), ("mass_kg: 0.02", "mass_kg: 0.78")),
    ),
    # the tool taken down to 0 mm with a 30 mm block's place at the table: the fingertips are
    # driven into the table (a fixed robot's link on the floor)
    Case(
        "pick_and_place, tool into the table",
        "fail",
        variant(
            PICK, ("at: [102.8, 122.6, 20], pitch: -80", "at: [102.8, 122.6, -10], pitch: -80")
        ),
    ),
    # a fixed (massless) block where the fingers close: the hand touches scenery
    Case(
        "pick_and_place, block fixed",
        "fail",
        variant(PICK, ("    mass_kg: 0.02\n    place_at_m: [0.1028, -0.1226, 0]\n", "")),
    ),
    # the 1 kg payload swung between ±25° as fast as the joint limits allow: holding it there
    # takes most of the torque, driving it at speed the rest and more: the shoulder stalls
    Case("arm3 fast swing of 1 kg", "fail", file(DATA / "too_fast.yaml"), "first"),
    # --- should warn ----------------------------------------------------------------------------
    # the same swing slowly: the servo keeps up, but turning round at 25° with 1 kg held out
    # needs over 80 % of its stall torque: a near miss
    Case("arm3 slow swing of 1 kg", "warn", file(DATA / "slow_swing.yaml"), "first"),
    # a 1 kg payload held at 30° needs ~60 % of stall: the arm gives ~4°, the tip 26 mm off
    Case("arm3 payload held at 30°", "warn", file(DATA / "reach_sags.yaml")),
    # left_move_fast played 6 times: 100 % of stall torque for tens of ms, again and again
    Case(
        "tonypi left_move_fast x6", "warn", repeated(MOTIONS / "tonypi" / "left_move_fast.yaml", 6)
    ),
    # a 9 mm tool move that IK can only meet on another branch of the arm (elbow 108°)
    Case("arm6 9 mm move on another branch", "warn", file(SPATIAL / "branch_jump.yaml")),
    # the shoulder swung -80..80° at full speed with the arm's own weight: it lags at the limit
    Case("arm6 shoulder sweep", "warn", file(DATA / "arm6_shoulder_sweep.yaml")),
    # the gripper closed to 0° on the block and held 2 s: its servo at stall torque for 5 s,
    # stopped by the block it carries (at 20°): worth a look, not a failure
    Case(
        "pick_and_place, squeezed at stall",
        "warn",
        variant(
            PICK,
            (
                "  - pose: {gripper: 16}\n    after: 0.5\n    hold: 0.3\n",
                "  - pose: {gripper: 0}\n    after: 0.5\n    hold: 2.0\n",
            ),
        ),
    ),
    # walk_forward with lift: 0: the swinging feet slide, friction holds them, it goes nowhere
    Case(
        "hexapod walk_forward with lift 0",
        "warn",
        variant(HEX / "walk_forward.yaml", ("lift: 30,", "lift: 0,")),
    ),
    # --- should pass ----------------------------------------------------------------------------
    # nothing touches, nothing strains
    Case("arm3 harmless motion", "pass", file(DATA / "fine.yaml")),
    # the arm3 with its 1 kg payload left hanging straight down: no torque to speak of
    Case(
        "arm3 1 kg payload at rest",
        "pass",
        variant(DATA / "too_heavy.yaml", ("shoulder: 90", "shoulder: 0")),
    ),
    # the block gripped, carried and set down 4 mm from its target
    Case("arm6 pick_and_place", "pass", file(PICK)),
    # a 150 g block in the 19° grip: 2.5 times the friction it needs, carried without creeping
    Case(
        "pick_and_place, 150 g block",
        "pass",
        variant(PICK, ("gripper: 16}", "gripper: 19}"), ("mass_kg: 0.02", "mass_kg: 0.15")),
    ),
    # the declared lie-down: the torso on the floor is what it means to do
    Case("hexapod lies down, declared", "pass", file(DATA / "lie_down_declared.yaml")),
    # stand_up from lying
    Case("hexapod stand_up", "pass", file(HEX / "stand_up.yaml")),
    # six tripod steps: 232 of 240 mm, feet rising 102 % of the lift (the robot file commands
    # 7 mm more lift and 6 % more stride, for the servos' sag under the body and the slip)
    Case("hexapod walk_forward", "pass", file(HEX / "walk_forward.yaml")),
    # a 60° turn on the spot: +61°
    Case("hexapod turn_in_place", "pass", file(HEX / "turn_in_place.yaml")),
    # ripple then wave sideways
    Case("hexapod side_step", "pass", file(HEX / "side_step.yaml")),
    # walk_forward in the ripple gait at 1.5 s a step (the shortest period its limits allow):
    # one leg per side in the air, four or five feet always down, the body >= 79 mm inside
    # them, a fresh swing every 1/4 s
    Case(
        "hexapod ripple walk",
        "pass",
        variant(
            HEX / "walk_forward.yaml", ("pattern: tripod", "pattern: ripple"), ("2.0}", "1.5}")
        ),
    ),
    # turn_in_place in the ripple gait: the swings overlap while all six coxas turn the body
    Case(
        "hexapod ripple turn",
        "pass",
        variant(HEX / "turn_in_place.yaml", ("pattern: tripod", "pattern: ripple")),
    ),
    # body rolled 6° with all feet planted: a planned tilt is no stumble
    Case("hexapod body_sway", "pass", file(HEX / "body_sway.yaml")),
    # body poses with all feet planted
    Case("hexapod body poses", "pass", file(SPATIAL / "body_pose.yaml")),
    # one leg waved high: the plan holds it up, the other five stand
    Case("hexapod wave_front_leg", "pass", file(HEX / "wave_front_leg.yaml")),
    # left_move_fast once: a short push at the limit, less than 0.1 s in all
    Case("tonypi left_move_fast", "pass", file(MOTIONS / "tonypi" / "left_move_fast.yaml")),
    # a humanoid bow
    Case("tonypi bow", "pass", file(MOTIONS / "tonypi" / "bow.yaml")),
    # a humanoid reaching and clapping with Cartesian hand targets
    Case("tonypi reach and clap", "pass", file(SPATIAL / "reach_and_clap.yaml")),
]


def verdict(results) -> str:
    if any(r.severity is Severity.ERROR for r in results):
        return "fail"
    return "warn" if results else "pass"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", default="", help="run only cases whose name contains this")
    args = parser.parse_args()
    counts = {"false negatives": 0, "false positives": 0, "right": 0}
    by_expected: dict[str, int] = {}
    started = time.perf_counter()
    with tempfile.TemporaryDirectory() as folder:
        for case in CASES:
            if args.only not in case.name:
                continue
            motion = case.load(Path(folder))
            results = run_checks(simulate_motion(motion, start_pose=case.start_pose))
            got = verdict(results)
            by_expected[case.expected] = by_expected.get(case.expected, 0) + 1
            if ORDER[got] < ORDER[case.expected]:
                mark = "FALSE NEGATIVE"
                counts["false negatives"] += 1
            elif ORDER[got] > ORDER[case.expected]:
                mark = "FALSE POSITIVE"
                counts["false positives"] += 1
            else:
                mark = "ok"
                counts["right"] += 1
            first = results[0].message[:90] if results else ""
            print(f"{case.name:42} expected {case.expected:4}  got {got:4}  {mark:14} {first}")
    cases = ", ".join(f"{n} should {kind}" for kind, n in sorted(by_expected.items()))
    print(
        f"\n{sum(by_expected.values())} cases ({cases}): {counts['false negatives']} false "
        f"negative(s), {counts['false positives']} false positive(s), {counts['right']} right "
        f"({time.perf_counter() - started:.0f} s)"
    )


if __name__ == "__main__":
    main()
