"""The learned simulators (sphkit.learn, ``sphkit learn``): dataset windows, the radius graph,
normalisation, noise, training, checkpoints, rollouts and evaluation, on tiny synthetic data."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

torch = pytest.importorskip("torch")
h5py = pytest.importorskip("h5py")

from sphkit.cli import main  # noqa: E402
from sphkit.io.datasets import frame_statistics  # noqa: E402
from sphkit.learn.data import (  # noqa: E402
    INPUT_SEQ_LENGTH,
    Normalizer,
    WindowDataset,
    load_split,
    read_metadata,
)
from sphkit.learn.graph import brute_force_graph, radius_graph  # noqa: E402
from sphkit.learn.sanchez_gonzalez2020 import GNSConfig  # noqa: E402
from sphkit.learn.train import (  # noqa: E402
    TrainConfig,
    Trainer,
    noisy_window,
    random_walk_noise,
)

DX = 0.1  # particle spacing of the synthetic data [m]
DT = 0.05  # frame interval [s]
G = -9.81 * DT ** 2  # gravity per frame^2 [m]
DRAG = 0.2  # fraction of the frame velocity lost per frame
FRAMES = 16


def _trajectory(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """A 4 x 4 block of fluid particles falling with linear drag, each with its own initial
    velocity, beside a static row of wall particles: ``x[t+1] = x[t] + (1 - DRAG)(x[t] -
    x[t-1]) + g``, so the frame acceleration ``-DRAG v + g`` is a function of the input
    velocity, which the network sees."""
    gx, gy = np.meshgrid(np.arange(4) * DX, np.arange(4) * DX, indexing="ij")
    x0 = np.stack([gx.ravel() + 1.0, gy.ravel() + 5.0], axis=1)
    v = rng.uniform(-0.05, 0.05, size=x0.shape)
    xs = [x0 - v, x0]
    for _ in range(FRAMES - 2):
        xs.append(xs[-1] + (1 - DRAG) * (xs[-1] - xs[-2]) + np.array([0.0, G]))
    fluid = np.stack(xs)
    walls = np.stack([np.arange(6) * DX + 0.9, np.full(6, 0.5)], axis=1)
    pos = np.concatenate([fluid, np.broadcast_to(walls, (FRAMES, 6, 2))], axis=1)
    return pos.astype(np.float32), np.array([0] * 16 + [1] * 6)


@pytest.fixture(scope="module")
def dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A tiny dataset in LagrangeBench's layout (4 train, 1 valid, 2 test trajectories)."""
    root = tmp_path_factory.mktemp("ds")
    rng = np.random.default_rng(1)
    trajs = {}
    for split, n in (("train", 4), ("valid", 1), ("test", 2)):
        with h5py.File(root / f"{split}.h5", "w") as f:
            for j in range(n):
                pos, pt = _trajectory(rng)
                g = f.create_group(f"{j:05d}")
                g["position"], g["particle_type"] = pos, pt
        trajs[split] = load_split(root, split)
    stats = frame_statistics([(t.position, t.particle_type) for t in trajs["train"]])
    meta = {"dt": DT, "write_every": 1, "dim": 2, "bounds": [[0.0, 3.0], [-10.0, 6.0]],
            "periodic_boundary_conditions": [False, False], "default_connectivity_radius": 0.15,
            "dx": DX, **stats, "sequence_length_train": FRAMES, "num_particles_max": 22,
            "sphkit": {"synthetic": "falling with drag"}}
    (root / "metadata.json").write_text(json.dumps(meta))
    return root


def _config(**kw: object) -> TrainConfig:
    base = dict(batch=2, lr=3e-3, lr_final=1e-4, lr_decay_steps=400, noise_std=0.0,
                report_seconds=1e9, checkpoint_every=10 ** 9, checkpoint_seconds=1e9,
                gns=GNSConfig(latent=16, layers=1, mlp_layers=1))
    base.update(kw)
    return TrainConfig(**base)  # type: ignore[arg-type]


@pytest.fixture(autouse=True)
def _one_thread() -> Iterator[None]:
    """One thread for PyTorch and Numba: on graphs of 22 nodes the parallel loops' start-up
    (5-8 ms per neighbour search on two busy cores) was nine tenths of the training test."""
    import numba

    threads = torch.get_num_threads(), numba.get_num_threads()
    torch.set_num_threads(1)
    numba.set_num_threads(1)
    yield
    torch.set_num_threads(threads[0])
    numba.set_num_threads(threads[1])


def test_windows_and_targets(dataset: Path) -> None:
    trajs = load_split(dataset, "train")
    ds = WindowDataset(trajs)
    assert len(ds) == 4 * (FRAMES - INPUT_SEQ_LENGTH)
    w, pt = ds[FRAMES - INPUT_SEQ_LENGTH + 3]  # trajectory 1, window start 3
    assert w.shape == (22, INPUT_SEQ_LENGTH + 1, 2) and pt.shape == (22,)
    np.testing.assert_array_equal(w.numpy()[:, -1], trajs[1].position[3 + INPUT_SEQ_LENGTH])
    np.testing.assert_array_equal(w.numpy()[:, 0], trajs[1].position[3])
    # the target acceleration of the data is -DRAG v + g (float32 positions: 1e-5 m)
    x = w.numpy().astype(np.float64)[:16]
    acc = x[:, -1] - 2 * x[:, -2] + x[:, -3]
    np.testing.assert_allclose(acc, -DRAG * (x[:, -2] - x[:, -3]) + [0.0, G], atol=2e-5)


def test_graph_matches_brute_force() -> None:
    rng = np.random.default_rng(3)
    x = rng.uniform(0.0, 1.0, size=(300, 2))
    mask = rng.uniform(size=300) < 0.7
    s, r = radius_graph(x, 0.08, mask)
    got = set(zip(s.tolist(), r.tolist(), strict=True))
    assert len(got) == len(s)  # no duplicates
    assert got == brute_force_graph(x, 0.08, mask)
    # periodic along x: the minimum image
    s, r = radius_graph(x, 0.08, None, [True, False], [[0.0, 1.0], [0.0, 1.0]])
    shifted = x.copy()
    shifted[:, 0] = (shifted[:, 0] + 0.5) % 1.0  # the seam moved to the middle
    assert set(zip(s.tolist(), r.tolist(), strict=True)) == brute_force_graph(shifted, 0.08) \
        | brute_force_graph(x, 0.08)


def test_normalisation_round_trip(dataset: Path) -> None:
    meta = read_metadata(dataset)
    n = Normalizer(meta, noise_std=1e-3)
    a = np.random.default_rng(0).normal(size=(50, 2))
    np.testing.assert_allclose(n.denorm_acc(n.norm_acc(a)), a, rtol=1e-12)
    t = torch.as_tensor(a)
    np.testing.assert_allclose(n.denorm_acc(n.norm_acc(t)).numpy(), a, rtol=1e-12)
    # LagrangeBench widens the statistics by the noise
    np.testing.assert_allclose(n.acc_std, np.hypot(meta["acc_std"], 1e-3))
    restored = Normalizer.from_state(n.state())
    np.testing.assert_allclose(restored.acc_std, n.acc_std)


def test_every_fluid_phase_moves_and_walls_stay() -> None:
    """A dataset of several fluids labels phase k >= 1 with type 3 + k (sphkit.io.datasets):
    the rollouts move those particles as fluid and keep walls (1) in place, the constant-
    velocity baseline and the GNS step alike (the step's fixed particles are the non-fluid
    ones)."""
    from sphkit.learn.rollout import constant_velocity
    from sphkit.learn.sanchez_gonzalez2020 import LearnedSimulator

    hist = np.zeros((6, 3, 2))
    hist[-1, :, 0] = 0.1  # every particle moved by 0.1 in the last frame
    ptype = np.array([0, 4, 1])
    out = constant_velocity(hist, ptype, 2)
    np.testing.assert_allclose(out[:, :, 0], [[0.2, 0.2, 0.1], [0.3, 0.3, 0.1]])
    gns = LearnedSimulator.__new__(LearnedSimulator)  # a model predicting no acceleration
    gns.acceleration = lambda history, particle_type: np.zeros((len(history), 2))
    np.testing.assert_allclose(gns.step(hist.transpose(1, 0, 2), ptype)[:, 0], [0.2, 0.2, 0.1])


def test_random_walk_noise() -> None:
    rng = np.random.default_rng(0)
    noise = random_walk_noise(20000, 5, 2, 0.01, rng)
    assert noise.shape == (20000, 6, 2) and not noise[:, 0].any()
    last_velocity = noise[:, -1] - noise[:, -2]
    assert abs(last_velocity.std() - 0.01) < 3e-4  # the last velocity's noise has noise_std
    w = np.zeros((3, 7, 2))
    inputs, target = noisy_window(w, np.array([0, 0, 1]), 0.01, rng)
    np.testing.assert_array_equal(target[:2], inputs[:2, -1])  # the target moves with the input
    assert not inputs[2].any() and not target[2].any()  # walls are not noised


def test_training_learns_the_acceleration(dataset: Path, tmp_path: Path) -> None:
    """Falling with drag: the acceleration is a linear function of the last velocity. After
    150 steps the one-step error of the normalised acceleration must be under 0.05 (the
    acceleration within about 20 % of its spread; the untrained network is at about 0.26) and
    a tenth of the untrained one, and the 10-step rollouts must beat the constant-velocity
    baseline (which misses gravity, 2.5 cm per frame^2, and the drag) tenfold in MSE (measured:
    0.001 and about 800 times)."""
    tr = Trainer(dataset, tmp_path / "m", _config(steps=150, lr=5e-3))
    before = tr.validation_loss()
    tr.run()
    after = tr.validation_loss()
    assert before is not None and after is not None
    assert after < min(0.05, before / 10), (before, after)
    from sphkit.learn.evaluate import evaluate

    res = evaluate(tmp_path / "m", dataset, "test", say=lambda s: None, starts=2)
    assert res["mse_ratio_cv_over_model"]["full"] > 10, res["mse"]


def test_checkpoint_and_resume(dataset: Path, tmp_path: Path) -> None:
    """Training 6 steps at once and 3 + 3 with a resume end with the same step and the same
    parameters (the optimiser moments and the random streams are restored)."""
    Trainer(dataset, tmp_path / "a", _config(steps=6, noise_std=1e-3)).run()
    Trainer(dataset, tmp_path / "b", _config(steps=3, noise_std=1e-3)).run()
    resumed = Trainer(dataset, tmp_path / "b", _config(steps=6, noise_std=1e-3), resume=True)
    assert resumed.step == 3
    resumed.run()
    a = torch.load(tmp_path / "a" / "model.pt", weights_only=False)
    b = torch.load(tmp_path / "b" / "model.pt", weights_only=False)
    assert a["step"] == b["step"] == 6
    for k, v in a["model"].items():
        assert torch.equal(v, b["model"][k]), k


@pytest.fixture(scope="module")
def model(dataset: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("model")
    Trainer(dataset, out, _config(steps=2)).run()
    return out


def test_rollout_writes_frames(model: Path, tmp_path: Path) -> None:
    """A rollout from a scene with the dataset's spacing writes frames and a manifest that
    sphkit.io reads back and that ``sphkit render`` accepts."""
    from sphkit.io.frames import read_frame
    from sphkit.io.manifest import read_manifest

    scene = {"name": "tiny", "configuration": {"dim": 2, "particle_radius": DX / 2,
                                               "time": {"until": 0.15}},
             "fluid_blocks": [{"start": [0.1, 0.1], "end": [0.5, 0.5]}],
             "boxes": [{"min": [0.0, 0.0], "max": [1.0, 1.0]}],
             "output": {"formats": ["vtk"]}}
    path = tmp_path / "tiny.json"
    path.write_text(json.dumps(scene))
    out = tmp_path / "out"
    assert main(["learn", "rollout", str(model), str(path), "--out", str(out), "-q"]) == 0
    m = read_manifest(out)
    assert m["status"] == "finished" and len(m["frames"]) == 4  # t = 0 and 3 steps of 0.05 s
    f0 = read_frame(out / m["frames"][0]["files"][0])
    f3 = read_frame(out / m["frames"][3]["files"][0])
    assert f0["position"].shape == f3["position"].shape and len(f0["position"]) == 16
    assert np.all(np.isfinite(f3["position"])) and np.all(f3["density"] > 0)
    pytest.importorskip("matplotlib")
    assert main(["render", str(out), "--frames", "3", "--video", "none", "-q"]) == 0


def test_eval_prints_the_table(model: Path, dataset: Path, tmp_path: Path,
                               capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["learn", "eval", str(model), str(dataset), "--limit", "1",
                 "--out", str(tmp_path / "ev")]) == 0
    text = capsys.readouterr().out
    assert "MSE_20" in text and "constant velocity" in text and "baseline / GNS" in text
    res = json.loads((tmp_path / "ev" / "eval.json").read_text())
    assert set(res["mse"]["cv"]) == {"1", "5", "20", "full"} and res["trajectories"] == 1


@pytest.mark.parametrize("argv, words", [
    (["learn", "train", "/nonexistent/ds"], "DATASET"),
    (["learn", "eval", "/nonexistent/model", "{ds}"], "MODEL"),
    (["learn", "rollout", "/nonexistent/model", "dambreak-2d"], "MODEL"),
    (["learn", "rollout", "{model}", "no-such-scene"], "SCENE"),
    (["learn", "rollout", "{model}", "dambreak-2d", "--steps", "0"], "positive integer"),
    (["learn", "train", "{ds}", "--resume", "--out", "{tmp}/none"], "--resume"),
    (["learn", "train", "{ds}", "--out", "{model}"], "--resume"),
    (["learn", "train", "{ds}", "--lr", "nan"], "--lr"),
    (["learn", "train", "{ds}", "--radius", "inf"], "--radius"),
    (["learn", "train", "{ds}", "--noise", "-1"], "--noise"),
    (["learn", "rollout", "{model}", "dambreak-2d", "--until", "inf"], "--until"),
    (["learn", "eval", "{model}", "{ds}", "--starts", "x"], "--starts"),
])
def test_cli_errors_exit_2(argv: list[str], words: str, dataset: Path, model: Path,
                           tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    argv = [a.format(ds=dataset, model=model, tmp=tmp_path) for a in argv]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert words in err and "Traceback" not in err


def test_cli_scene_of_another_resolution(model: Path, tmp_path: Path,
                                         capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["learn", "rollout", str(model), "dambreak-2d", "--out",
                 str(tmp_path / "o")]) == 2
    assert "particle_radius" in capsys.readouterr().err


def test_cli_without_torch_or_gpu(monkeypatch: pytest.MonkeyPatch, dataset: Path,
                                  capsys: pytest.CaptureFixture[str]) -> None:
    import sphkit.learn

    monkeypatch.setattr(sphkit.learn, "missing", lambda: ["torch"])
    assert main(["learn", "train", str(dataset)]) == 2
    assert "install sphkit[learn] (PyTorch)" in capsys.readouterr().err
    monkeypatch.undo()
    if not torch.cuda.is_available():
        assert main(["learn", "train", str(dataset), "--device", "cuda"]) == 2
        assert "--device cuda" in capsys.readouterr().err


def test_sphkit_imports_without_torch() -> None:
    """The command and the library never import PyTorch until a learn command runs."""
    code = ("import sys; import sphkit, sphkit.cli, sphkit.learn; "
            "assert 'torch' not in sys.modules and 'h5py' not in sys.modules")
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).parents[1] / "src")}
    subprocess.run([sys.executable, "-c", code], check=True, env=env)


def _wall_box(dim: int, dx: float) -> np.ndarray:
    """Two layers of wall particles under the plane y = 0 (x, z in [-1, 1])."""
    s = np.arange(-1.0, 1.0 + 1e-9, dx)
    layers = (-0.5 * dx, -1.5 * dx)
    if dim == 2:
        return np.array([[a, y] for a in s for y in layers])
    return np.array([[a, y, c] for a in s for c in s for y in layers])


@pytest.mark.parametrize("dim", [2, 3])
def test_wall_collisions_stop_tunnelling_and_keep_the_slide(dim: int) -> None:
    """Rollout wall collisions (sphkit.learn.walls) against a two-layer wall of spacing dx:
    points thrown 4.5 dx a step into the wall at any angle and offset (the dam break's fastest
    splashes) end above the contact surface (0.25 dx above the top layer's centres, which lie at
    y = -dx/2), keep their tangential displacement (frictionless: the projection removes the
    normal part only; to 0.1 dx of slides up to 4.5 dx, measured at most 0.062 dx: the wall's
    normal, estimated from its lattice of particles, tilts a little), and points moving along or
    away from the wall are not touched."""
    from sphkit.learn.walls import WallCollision

    dx = 0.02
    walls = _wall_box(dim, dx)
    wc = WallCollision(walls, dx)
    rng = np.random.default_rng(0)
    n = 400
    x0 = np.zeros((n, dim))
    x0[:, 0] = rng.uniform(-0.5, 0.5, n)
    x0[:, 1] = rng.uniform(0.55, 2.0, n) * dx
    if dim == 3:
        x0[:, 2] = rng.uniform(-0.5, 0.5, n)
    step = rng.normal(size=(n, dim))
    step[:, 1] = -np.abs(step[:, 1]) - 0.3  # downwards, at every angle down to grazing
    step *= 4.5 * dx / np.linalg.norm(step, axis=1, keepdims=True)
    x1 = wc(x0, x0 + step)
    assert x1[:, 1].min() > -0.25 * dx, x1[:, 1].min() / dx
    tang = [k for k in range(dim) if k != 1]
    slid = x1[:, tang] - x0[:, tang]
    assert np.allclose(slid, step[:, tang], atol=0.1 * dx)  # a flat wall: the slide is kept
    # along the wall at rest height (one dx above the top layer) and away from it: untouched
    y = np.zeros((3, dim))
    y[:, 1] = 0.5 * dx
    move = np.zeros((3, dim))
    move[0, 0], move[1, 1], move[2, 0], move[2, 1] = 4 * dx, 3 * dx, -2 * dx, 0.5 * dx
    assert np.array_equal(wc(y, y + move), y + move)


def test_collisions_keep_the_baseline_in_the_tank() -> None:
    """The constant-velocity baseline thrown at the floor: free, it leaves through the wall;
    with collisions (as ``sphkit learn eval`` runs it by default) it slides along the floor
    with its horizontal velocity (kept to 3 %: the wall's estimated normal tilts by up to 0.3 %
    and the impact step is cut at a sample) and its vertical motion stopped (below 1 % of the
    0.03 m per frame it came in with)."""
    from sphkit.learn.rollout import constant_velocity, outside
    from sphkit.learn.walls import WallCollision

    dx = 0.02
    walls = _wall_box(2, dx)
    x = np.array([[0.0, 0.1], [0.2, 0.05]])
    hist = np.stack([x - np.array([0.01, -0.03]), x])  # 1.5 dx per frame down, 0.5 dx across
    pt = np.array([0, 0])
    bounds = [[-1.0, 1.0], [-2.5 * dx, 1.0]]
    free = constant_velocity(hist, pt, 20)
    hit = constant_velocity(hist, pt, 20, WallCollision(walls, dx))
    assert outside(free[-1], bounds) == 2
    assert max(outside(p, bounds) for p in hit) == 0
    vel = np.diff(hit[-6:], axis=0)
    assert np.allclose(vel[..., 0], 0.01, rtol=0.03), vel[..., 0]
    assert np.abs(vel[..., 1]).max() < 0.01 * 0.03, vel[..., 1]
