"""Simulation.run's frame counter: without an on_frame callback it jumps to the frame count
instead of stepping through every frame (a huge fps made each step spin through millions of
empty frames), and ends where the callback path ends."""

from __future__ import annotations

from sphkit.simulation import Simulation


def test_frame_counter_without_callback_matches_the_callback_path() -> None:
    frames: list[int] = []
    a = Simulation.from_scene("hydrostatic-2d")
    a.run(until=0.05, fps=200.0, on_frame=lambda s, k: frames.append(k))
    b = Simulation.from_scene("hydrostatic-2d")
    b.run(until=0.05, fps=200.0)
    assert frames == list(range(len(frames)))  # one call per frame, none skipped
    assert b._frame == a._frame == frames[-1]
    assert a.time == b.time
    c = Simulation.from_scene("hydrostatic-2d")
    c.run(until=0.01, fps=1e9)  # returns promptly: about 1e7 frames, not looped over
    assert abs(c._frame - c.time * 1e9) <= 2
