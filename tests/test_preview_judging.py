def test_a_stumble_onto_lifted_legs_is_judged_against_the_plan():
    """four_legs_up.yaml leaves the hexapod on its two middle feet: it pitches over them and its
    body comes down ~7 mm onto two of the lifted legs. The old rules miss it (no link but the
    tibias touches the floor, a few degrees of tilt, far from half its height); against the
    plan, the body is lower than planned and two feet the plan holds 15 mm up are on the floor."""
    rollout = simulate_motion(load_motion(MOTIONS / "four_legs_up.yaml"))
    results = run_checks(rollout)
    assert {(r.kind, r.severity) for r in results} == {(CheckKind.FALL, Severity.ERROR)}
    lower = [r for r in results if "lower than its plan" in r.message]
    assert len(lower) == 1 and lower[0].value > 5
    down = sorted(r.bodies[0] for r in results if "lifted leg" in r.message)
    assert len(down) == 2 and all(
        foot in ("lf_tibia", "lr_tibia", "rf_tibia", "rr_tibia") for foot in down
    )
    # the plan: the four corner feet 15 mm up, the two middle ones on the floor
    lifts = 1000 * rollout.stance.lift_m[np.searchsorted(rollout.times_s, 1.0)]
    planned = dict(zip(rollout.stance.foot_links, lifts))
    assert planned["lm_tibia"] < 1 and planned["rm_tibia"] < 1
    assert all(abs(planned[f] - 15) < 1 for f in ("lf_tibia", "lr_tibia", "rf_tibia", "rr_tibia"))
