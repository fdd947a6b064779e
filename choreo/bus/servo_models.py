"""Servo model specifications and the defaults derived from them (one table, overridable).

Source: the vendor's datasheets, as tabled in ``docs/servo-models.md`` with every value below and
where it comes from. Velocity limit for planning = 80 % of no-load speed;
acceleration and jerk have no vendor figure (3000 °/s², 30000 °/s³ as a starting point).
MuJoCo actuator: forcerange = ± stall torque, damping = stall / no-load speed,
kp = stall / 0.105 rad (saturates at ~6° of error), armature 0.005 kg·m².

Assumptions with no vendor figure: the datasheet torque and speed hold at
the rated supply (7.4 V for the LX-16A, 11.1 V for the HV models) and scale in proportion to the
supply; a dead band of one position unit (0.24°) and 0.5° of gear backlash.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

UNITS_PER_DEG = 1000 / 240  # 0.24° per position unit
DEG_PER_UNIT = 240 / 1000
POSITION_RANGE_UNITS = (0, 1000)
KGCM_TO_NM = 0.0981
DEADBAND_DEG = DEG_PER_UNIT  # assumed: the servo cannot act on less than its resolution
BACKLASH_DEG = 0.5  # assumed: typical of small metal-gear servos, not measured on these
VELOCITY_LIMIT_SHARE = 0.8  # of the no-load speed: the default velocity limit for planning


@dataclass(frozen=True)
class ServoModel:
    name: str
    stall_torque_nm: float
    no_load_speed_deg_s: float
    vin_range_mv: tuple[int, int]  # rated supply
    answers_wait_read: bool = True  # cmd 8 MOVE_TIME_WAIT_READ
    answers_dis_read: bool = True  # cmd 48 DIS_READ
    acc_limit_deg_s2: float = 3000.0
    jerk_limit_deg_s3: float = 30000.0
    armature_kg_m2: float = 0.005
    rated_supply_v: float = 11.1  # the datasheet's torque and speed are at this supply
    deadband_deg: float = DEADBAND_DEG
    backlash_deg: float = BACKLASH_DEG

    @property
    def vel_limit_deg_s(self) -> float:
        return VELOCITY_LIMIT_SHARE * self.no_load_speed_deg_s

    def supply_scale(self, supply_v: float | None) -> float:
        """How much of its rated torque and speed the servo has at ``supply_v`` (None: the
        rated supply): in proportion to the supply (assumed)."""
        return 1.0 if supply_v is None else supply_v / self.rated_supply_v

    def vel_limit_at(
        self, supply_v: float | None, no_load_speed_deg_s: float | None = None
    ) -> float:
        """The default velocity limit for planning at ``supply_v``, of a servo whose no-load
        speed at the rated supply is ``no_load_speed_deg_s`` (None: the datasheet's)."""
        speed = self.no_load_speed_deg_s if no_load_speed_deg_s is None else no_load_speed_deg_s
        return VELOCITY_LIMIT_SHARE * speed * self.supply_scale(supply_v)

    @property
    def damping_nm_s_rad(self) -> float:
        return self.stall_torque_nm / math.radians(self.no_load_speed_deg_s)

    @property
    def kp_nm_rad(self) -> float:
        return self.stall_torque_nm / 0.105


# What a robot file's ``actuator:`` block may override per joint (the preview's servo model).
# stall_torque_nm, kp_nm_rad and no_load_speed_deg_s are figures at the rated supply.
ACTUATOR_FIELDS = (
    "stall_torque_nm",
    "kp_nm_rad",
    "damping_nm_s_rad",
    "armature_kg_m2",
    "no_load_speed_deg_s",
    "supply_v",
    "deadband_deg",
    "backlash_deg",
    "friction_nm",
    "response_delay_s",
    "offset_deg",
)
# may be 0: an ideal servo (no dead band, no play, no friction, no delay)
ZERO_OK_ACTUATOR_FIELDS = ("deadband_deg", "backlash_deg", "friction_nm", "response_delay_s")
# any sign: the horn mounted a little off the joint's zero, either way
SIGNED_ACTUATOR_FIELDS = ("offset_deg",)
MAX_RESPONSE_DELAY_S = 0.1  # a servo that answers a move this late is broken, not slow


SERVO_MODELS: dict[str, ServoModel] = {
    m.name: m
    for m in (
        ServoModel(
            "LX-16A",
            17 * KGCM_TO_NM,
            60 / 0.16,
            (6000, 8400),
            answers_wait_read=False,
            answers_dis_read=False,
            rated_supply_v=7.4,
        ),
        ServoModel("LX-224HV", 20 * KGCM_TO_NM, 60 / 0.19, (9000, 12600)),
        ServoModel("LX-824HV", 17 * KGCM_TO_NM, 60 / 0.20, (9000, 12600)),
        ServoModel("HTD-35H", 35 * KGCM_TO_NM, 60 / 0.18, (9000, 12600)),
        # Not confirmed by the vendor: treated as LX-224HV-like until measured.
        ServoModel("LX-224", 20 * KGCM_TO_NM, 60 / 0.19, (9000, 12600)),
        ServoModel("LX-225", 20 * KGCM_TO_NM, 60 / 0.19, (9000, 12600)),
        ServoModel("LX-15D", 20 * KGCM_TO_NM, 60 / 0.19, (9000, 12600)),
    )
}


def servo_model(name: str) -> ServoModel:
    """The model called ``name``; ``ValueError`` listing the known models otherwise."""
    try:
        return SERVO_MODELS[name]
    except KeyError:
        raise ValueError(
            f"unknown servo model {name!r}; known models: {', '.join(SERVO_MODELS)}"
        ) from None


def rated_supply_problem(name: str, supply_v: float) -> str | None:
    """Why ``supply_v`` does not suit the servo model ``name`` (outside its rated supply), or
    None: one rule for the robot file's declared supply and the supply a servo reads."""
    model = servo_model(name)
    low, high = model.vin_range_mv
    if low <= 1000 * supply_v <= high:
        return None
    rated = f"{low / 1000:g}-{high / 1000:g} V"
    return f"supply {supply_v:g} V is outside the {model.name}'s rated {rated}"
