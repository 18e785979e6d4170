"""Simulation.run's frame counter: without an on_frame callback it jumps to the frame count
instead of stepping through every frame (a huge fps made each step spin through millions of
empty frames), and ends where the callback path ends."""

from __future__ import annotations

from sphkit.scene.files import load_scene
from sphkit.simulation import Simulation


def test_frame_counter_without_callback_matches_the_callback_path() -> None:
    frames: list[int] = []
    # the frame counter only: no start-up settling (20 acoustic periods of this column)
    a = Simulation(load_scene("hydrostatic-2d"), settle=False)
    a.run(until=0.05, fps=200.0, on_frame=lambda s, k: frames.append(k))
    b = Simulation(load_scene("hydrostatic-2d"), settle=False)
    b.run(until=0.05, fps=200.0)
    assert frames == list(range(len(frames)))  # one call per frame, none skipped
    assert b._frame == a._frame == frames[-1]
    assert a.time == b.time
    c = Simulation(load_scene("hydrostatic-2d"), settle=False)
    c.run(until=0.01, fps=1e9)  # returns promptly: about 1e7 frames, not looped over
    assert abs(c._frame - c.time * 1e9) <= 2
    # a frame rate or end time that is no number is refused naming it, before any step
    for kwargs, word in (({"fps": 0.0}, "fps 0.0"), ({"until": float("nan")}, "until nan")):
        try:
            c.run(**kwargs)
        except ValueError as e:
            assert word in str(e)
        else:
            raise AssertionError(f"run({kwargs}) was accepted")
