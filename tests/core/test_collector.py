"""choreo.core.collector: the cyclic garbage collector paused while choreo builds much that is
no garbage, and left as it was found."""

from __future__ import annotations

import gc

from choreo.core.collector import collector_paused


def test_the_collector_is_paused_inside_and_given_back_as_the_outermost_pause_found_it():
    assert gc.isenabled()
    with collector_paused():
        assert not gc.isenabled()
        with collector_paused():  # a motion reading its robot
            assert not gc.isenabled()
        assert not gc.isenabled()  # the inner pause leaves it to the outer one
    assert gc.isenabled()
    gc.disable()  # a program that runs without the collector keeps it off
    try:
        with collector_paused():
            pass
        assert not gc.isenabled()
    finally:
        gc.enable()


def test_the_collector_runs_again_after_a_pause_that_ended_in_an_error():
    try:
        with collector_paused():
            raise ValueError("a file refused")
    except ValueError:
        pass
    assert gc.isenabled()
