"""visguide.tracking against the cbt-tracker crate (tests/reference.json): a CBT learned from
the same simulated sequences, the Kalman and particle-filter baselines, round trips, errors."""

import ast
import copy
import json
import pathlib
import pickle
import threading

import numpy as np
import pytest

from visguide.tracking import CBT, Kalman, ParticleFilter


def frames(ref_frames):
    """(truths, detections) arrays per frame, as the reference stores them."""
    return [(np.array(t, dtype=float).reshape(-1, 2), np.array(d, dtype=float).reshape(-1, 3)) for t, d in ref_frames]


def estimates(tracker, test):
    start = tuple(test[0][0][0])
    tracker.reset(start)
    return [list(tracker.step(d)) for _, d in test[1:]]


@pytest.fixture(scope="module")
def data(reference):
    ref = reference["tracking"]
    return ref, [frames(s) for s in ref["train"]], frames(ref["test"])


def make_kalman():
    return Kalman(2.0, 3.0, 10.0)


def make_pf():
    return ParticleFilter(2.0, 3.0, 0.9, 1e-4, 10.0, n=200, seed=3)


def test_cbt_learned_in_python_tracks_exactly_as_in_rust(data):
    ref, train, test = data
    cbt = CBT.learn(train, 320.0, 240.0, spacing=10.0)
    assert estimates(cbt, test) == ref["cbt"]
    assert cbt.posterior.sum() == pytest.approx(1.0)


@pytest.mark.parametrize("name, make", [("kalman", make_kalman), ("particle_filter", make_pf)])
def test_baselines_track_exactly_as_in_rust(data, name, make):
    ref, _, test = data
    assert estimates(make(), test) == ref[name]


@pytest.mark.parametrize("make", [make_kalman, make_pf])
def test_run_equals_step_by_step(data, make):
    _, _, test = data
    a, b = make(), make()
    out = a.run(tuple(test[0][0][0]), [d for _, d in test[1:]])
    steps = estimates(b, test)
    assert out.shape == (len(test) - 1, 3)
    assert out[:, :2].tolist() == [s[:2] for s in steps]
    assert a == b


@pytest.mark.parametrize("make", [make_kalman, make_pf, None])
def test_a_refused_run_keeps_the_state(data, make):
    """``run`` with a frame that ``step`` refuses (NaN, a negative weight, off CBT's grid)
    raises and leaves the tracker as it was: it used to be left reset to ``start`` and stepped
    up to the bad frame."""
    _, train, test = data
    t = make() if make else CBT.learn(train, 320.0, 240.0, spacing=10.0)
    t.reset(tuple(test[0][0][0]))
    for _, d in test[1:5]:
        t.step(d)
    before = t.to_json()
    good = [d for _, d in test[5:15]]
    for bad in [np.array([[np.nan, 1.0]]), np.array([[1.0, 2.0, -1.0]])] + ([np.array([[1e6, 1.0]])] if make is None else []):
        with pytest.raises(ValueError):
            t.run(tuple(test[0][0][0]), good + [bad] + good)
        assert t.to_json() == before
    # A run that succeeds still leaves the tracker where the run ended.
    out = t.run(tuple(test[0][0][0]), good)
    assert t.estimate()[:2] == tuple(out[-1, :2])


def test_pickling_while_another_thread_runs_is_a_runtime_error():
    """``run`` holds the tracker while it steps without the GIL: pickling it from another
    thread meanwhile raises ``RuntimeError`` (already borrowed), as any other call on it does.
    It used to panic (``pyo3_runtime.PanicException``, not an ``Exception``)."""
    t = ParticleFilter(2.0, 3.0, 0.9, 1e-4, 10.0, n=100_000, seed=3)
    frames = [np.array([[100.0 + k, 50.0]]) for k in range(300)]
    worker = threading.Thread(target=t.run, args=((100.0, 50.0), frames))
    worker.start()
    refused = 0
    try:
        while worker.is_alive():
            try:
                pickle.dumps(t)
            except RuntimeError:
                refused += 1
    finally:
        worker.join()
    assert refused > 0
    assert pickle.loads(pickle.dumps(t)) == t


def test_two_column_detections_have_weight_one(data):
    _, _, test = data
    a, b = make_kalman(), make_kalman()
    start = tuple(test[0][0][0])
    a.reset(start)
    b.reset(start)
    for _, d in test[1:]:
        assert a.step(d[:, :2]) == b.step(np.c_[d[:, :2], np.ones(len(d))])
    assert a.step([]) == b.step(np.empty((0, 2)))


@pytest.mark.parametrize("make", [make_kalman, make_pf])
def test_pickle_json_and_file_round_trips(data, make, tmp_path):
    _, _, test = data
    t = make()
    t.reset(tuple(test[0][0][0]))
    for _, d in test[1:10]:
        t.step(d)
    path = tmp_path / "tracker.json"
    t.save(path)
    clones = [pickle.loads(pickle.dumps(t)), copy.deepcopy(t), type(t).from_json(t.to_json()), type(t).load(path)]
    rest = [d for _, d in test[10:]]
    for c in clones:
        assert c == t
    # Continuing from a clone gives what continuing the original gives.
    ref_steps = [t.step(d) for d in rest]
    for c in clones:
        assert [c.step(d) for d in rest] == ref_steps


def test_cbt_round_trips(data):
    _, train, test = data
    cbt = CBT.learn(train[:1], 320.0, 240.0)
    cbt.reset(tuple(test[0][0][0]))
    c = pickle.loads(pickle.dumps(cbt))
    assert c == cbt
    assert [c.step(d) for _, d in test[1:6]] == [cbt.step(d) for _, d in test[1:6]]


def test_step_on_grid_leaves_out_only_the_detections_off_the_grid(data):
    _, train, test = data
    a = CBT.learn(train, 320.0, 240.0, spacing=10.0)
    b = CBT.from_json(a.to_json())
    start = tuple(test[0][0][0])
    a.reset(start)
    b.reset(start)
    far = np.array([[1000.0, 1000.0, 1.0]])
    for _, d in test[1:8]:
        before = a.to_json()
        with pytest.raises(ValueError):
            a.step(np.vstack([d, far]))
        assert a.to_json() == before
        x, y, c, left_out = a.step_on_grid(np.vstack([d, far]))
        assert left_out == 1
        assert (x, y, c) == b.step(d)
    # A frame with nothing on the grid is a step without detections.
    assert a.step_on_grid(far) == (*b.step(np.zeros((0, 3))), 1)
    before = a.to_json()
    with pytest.raises(ValueError):
        a.step_on_grid(np.array([[np.nan, 1.0]]))
    assert a.to_json() == before
    # Trackers without a grid leave nothing out.
    k, k2 = make_kalman(), make_kalman()
    k.reset(start)
    k2.reset(start)
    assert k.step_on_grid(far) == (*k2.step(far), 0)


def test_bad_input(data, tmp_path):
    _, train, test = data
    k = make_kalman()
    k.reset((10.0, 10.0))
    before = k.to_json()
    for bad in [np.array([[np.nan, 1.0]]), np.array([[1.0, 2.0, -1.0]]), np.zeros((2, 4))]:
        with pytest.raises(ValueError):
            k.step(bad)
    assert k.to_json() == before
    with pytest.raises(TypeError):
        k.step(np.zeros(3))
    with pytest.raises(ValueError):
        k.reset((np.nan, 0.0))
    with pytest.raises(ValueError):
        Kalman(-1.0, 3.0, 10.0)
    with pytest.raises(ValueError):
        ParticleFilter(2.0, 3.0, 0.9, 1e-4, 10.0, n=0)
    with pytest.raises(ValueError):
        CBT.learn([], 320.0, 240.0)
    with pytest.raises(ValueError):
        CBT.learn(train, -1.0, 240.0)
    # A grid too fine for the (default, separable) layout: a ValueError, where the model's
    # 10^10-number allocation used to abort the interpreter.
    with pytest.raises(ValueError, match="coarser spacing"):
        CBT.learn(train, 1e5, 1e5, 1.0)
    with pytest.raises(ValueError):
        Kalman.from_json('{"not": "a tracker"}')
    with pytest.raises(OSError):
        Kalman.load(tmp_path / "missing.json")
    with pytest.raises(OSError):
        k.save(tmp_path / "no" / "dir" / "k.json")
    assert not (tmp_path / "no").exists()


def test_kalman_state_attributes():
    k = make_kalman()
    k.reset((5.0, 6.0))
    assert k.x[:2] == [5.0, 6.0] and k.P.shape == (4, 4)
    assert len(make_pf()) == 200


# --- CBT beyond the default configuration (the keywords of `tracking_cases` in reference.rs) ---

CONFIGS = {
    "first_order_subtract": dict(
        order="first",
        clutter="subtract",
        observation_fallback="uniform",
        prior_weight=2.0,
        mixing=0.01,
        prune=0.0,
        runner_ups=1,
    ),
    "stationary": dict(
        layout="stationary",
        system_fallback="constant_velocity",
        fallback_sigma=1.5,
        obs_radius=6,
        support=0.02,
        decode_radius=3,
    ),
    "sparse_joint_online": dict(
        layout="sparse_joint",
        clutter="uniform",
        observation_floor=0.01,
        online_weight=0.5,
        self_learning=True,
    ),
    # The image-tracking settings, and the stationary layout's options beside them.
    "real_motion": CBT.stationary_config(),
    "stationary_options": dict(
        CBT.stationary_config(), start="pooled", displacements="aligned", velocity="per_position"
    ),
}

# The options the crate's saved form leaves out while they hold their defaults (so that files
# written before an option existed still read); as keywords they are always there.
OPTIONS = dict(
    smoothing="fixed",
    start="marginal",
    displacements="channels",
    observation_smoothing="counted",
    velocity="factored",
)

DEFAULT_CONFIG = dict(
    order="second",
    layout="separable",
    clutter="model",
    observation_fallback="identity",
    system_fallback="first_order",
    prior_weight=1.0,
    fallback_sigma=1.0,
    observation_floor=1e-3,
    mixing=1e-3,
    prune=0.01,
    online_weight=1.0,
    runner_ups=3,
    obs_radius=10,
    support=1e-2,
    decode_radius=4,
    **OPTIONS,
)


@pytest.mark.parametrize("name", sorted(CONFIGS))
def test_cbt_configurations_track_exactly_as_in_rust(data, name):
    ref, train, test = data
    cbt = CBT.learn(train, 320.0, 240.0, 10.0, **CONFIGS[name])
    expected = dict(DEFAULT_CONFIG)
    expected.update({k: v for k, v in CONFIGS[name].items() if k != "self_learning"})
    assert cbt.config == expected
    # The learned model and its configuration survive JSON and pickling.
    for back in [pickle.loads(pickle.dumps(cbt)), CBT.from_json(cbt.to_json())]:
        assert back == cbt and back.config == expected
        assert estimates(back, test) == ref["cbt_configs"][name]
    assert estimates(cbt, test) == ref["cbt_configs"][name]


def test_cbt_default_configuration(data):
    _, train, _ = data
    assert CBT.default_config() == DEFAULT_CONFIG
    cbt = CBT.learn(train, 320.0, 240.0)
    assert cbt.config == DEFAULT_CONFIG
    # The keywords are the crate's serde form of CbtConfig, field for field, with their types
    # (the options at their defaults filled in).
    assert {**OPTIONS, **json.loads(cbt.to_json())["model"]["config"]} == cbt.config
    assert {k: type(v) for k, v in cbt.config.items()} == {k: type(v) for k, v in DEFAULT_CONFIG.items()}


def test_cbt_stationary_configuration_is_the_crates_and_reads_back(data):
    _, train, _ = data
    cfg = CBT.stationary_config()
    # The settings the crate docs give for image tracking and real motion.
    assert (cfg["layout"], cfg["order"], cfg["start"], cfg["displacements"]) == (
        "stationary",
        "second",
        "learned",
        "interpolated",
    )
    assert cfg.keys() == DEFAULT_CONFIG.keys()
    cbt = CBT.learn(train, 320.0, 240.0, 10.0, **cfg)
    assert cbt.config == cfg
    saved = json.loads(cbt.to_json())["model"]["config"]
    assert saved["start"] == "learned" and saved["displacements"] == "interpolated"
    assert {**OPTIONS, **saved} == cfg
    back = CBT.from_json(cbt.to_json())
    assert back == cbt and back.config == cfg


def test_cbt_configuration_takes_numpy_scalars(data):
    _, train, _ = data
    kw = dict(runner_ups=np.int64(1), prior_weight=np.float32(2.0), obs_radius=np.uint8(6))
    config = CBT.learn(train, 320.0, 240.0, **kw).config
    assert (config["runner_ups"], config["prior_weight"], config["obs_radius"]) == (1, 2.0, 6)


def test_stub_and_docstring_name_every_configuration_keyword():
    """The type stub's keywords of CBT.learn (names, types, defaults) and the docstring follow
    the crate's CbtConfig, whose serde form CBT.default_config() is."""
    stub = pathlib.Path(__file__).parents[1] / "visguide" / "_visguide.pyi"
    tree = ast.parse(stub.read_text())
    cls = next(n for n in tree.body if isinstance(n, ast.ClassDef) and n.name == "CBT")
    learn = next(n for n in cls.body if isinstance(n, ast.FunctionDef) and n.name == "learn")
    args = learn.args
    stub_kw = {a.arg: (a.annotation.id, ast.literal_eval(d)) for a, d in zip(args.kwonlyargs, args.kw_defaults)}
    assert stub_kw.pop("self_learning") == ("bool", False)
    defaults = CBT.default_config()
    assert stub_kw == {k: (type(v).__name__, v) for k, v in defaults.items()}
    for k in defaults:
        assert f"``{k}``" in CBT.learn.__doc__, k


@pytest.mark.parametrize(
    "kw",
    [
        dict(order="third"),
        dict(layout="dense"),
        dict(clutter="ignore"),
        dict(observation_fallback="gaussian"),
        dict(system_fallback="none"),
        dict(prior_weight=0.0),
        dict(prior_weight=float("nan")),
        dict(fallback_sigma=-1.0),
        dict(observation_floor=1.5),
        dict(mixing=-0.1),
        dict(prune=2.0),
        dict(online_weight=0.0),
        dict(support=float("inf")),
        dict(obs_radius=0),
        dict(obs_radius=65),
        dict(runner_ups=-1),
        dict(decode_radius=-2),
        dict(start="anywhere"),
        dict(displacements="sideways"),
        dict(velocity="PerParticle"),
        dict(smoothing="held_out"),
        dict(displacements="aligned"),
    ],
)
def test_invalid_cbt_configuration_is_a_value_error(data, kw):
    _, train, _ = data
    with pytest.raises(ValueError):
        CBT.learn(train, 320.0, 240.0, **kw)


@pytest.mark.parametrize(
    "kw, error, message",
    [
        (dict(order=3), ValueError, "order"),
        (dict(runner_ups=1.5), ValueError, "runner_ups"),
        (dict(prior_weight="big"), ValueError, "prior_weight"),
        (dict(displacements="sideways"), ValueError, "displacements"),
        (dict(velocity="PerParticle"), ValueError, "velocity"),
        (dict(layout=None), TypeError, "layout"),
        (dict(mixing=[0.1]), TypeError, "mixing"),
        (dict(ordre="first"), TypeError, "unexpected keyword argument 'ordre'"),
    ],
)
def test_wrong_cbt_keyword_names_itself(data, kw, error, message):
    _, train, _ = data
    with pytest.raises(error, match=message):
        CBT.learn(train, 320.0, 240.0, **kw)


def test_learn_online_adds_a_frame(data):
    _, train, test = data
    cbt = CBT.learn(train, 320.0, 240.0)
    before = CBT.from_json(cbt.to_json())
    truths, dets = test[1]
    cbt.learn_online(truths, dets)
    assert cbt != before
    with pytest.raises(ValueError):
        cbt.learn_online(np.array([[np.nan, 1.0]]), dets)


@pytest.mark.parametrize("make", [make_kalman, make_pf, None])
def test_refused_calls_keep_the_state_and_every_later_estimate(data, make):
    """``step``, ``step_on_grid`` and ``reset`` refuse bad input (a NaN position, a negative or
    NaN weight, a wrong column count, a NaN start; CBT also a start off its grid) with a
    ``ValueError`` and leave the tracker exactly as it was: its JSON (the particle filter's
    random state included) and every later estimate equal a twin's that never saw them."""
    _, train, test = data
    t = make() if make else CBT.learn(train, 320.0, 240.0, spacing=10.0)
    start = tuple(test[0][0][0])
    t.reset(start)
    for _, d in test[1:5]:
        t.step(d)
    twin = type(t).from_json(t.to_json())
    before = t.to_json()
    bad_frames = [
        np.array([[np.nan, 1.0]]),
        np.array([[1.0, np.inf, 1.0]]),
        np.array([[1.0, 2.0, -1.0]]),
        np.array([[1.0, 2.0, np.nan]]),
        np.zeros((2, 4)),
    ]
    for k, (_, d) in enumerate(test[5:9]):
        for bad in bad_frames:
            for call in [t.step, t.step_on_grid]:
                with pytest.raises(ValueError):
                    call(np.vstack([d[:, : bad.shape[1]], bad]) if bad.shape[1] <= 3 else bad)
        for bad_start in [(np.nan, 0.0), (0.0, np.inf)] + ([(1e6, 1e6)] if make is None else []):
            with pytest.raises(ValueError):
                t.reset(bad_start)
        # (Compared once per frame: a refused call's change would stay to the end.)
        assert t.to_json() == before, k
        assert t.step(d) == twin.step(d), k
        assert t == twin
        before = t.to_json()


def test_a_refused_online_frame_changes_nothing(data):
    """``learn_online`` with a NaN or off-grid truth, or a bad detection, raises and leaves both
    models as they were: the tracker learns and tracks on as a twin that never saw it."""
    _, train, test = data
    cbt = CBT.learn(train, 320.0, 240.0)
    twin = CBT.from_json(cbt.to_json())
    before = cbt.to_json()
    truths, dets = test[1]
    for bad_truths, bad_dets in [
        (np.array([[np.nan, 1.0]]), dets),
        (np.array([[1e6, 1e6]]), dets),
        (truths, np.array([[np.nan, 1.0, 1.0]])),
        (truths, np.array([[1.0, 2.0, -1.0]])),
        (truths, np.vstack([dets, [[1e6, 1e6, 1.0]]])),
    ]:
        with pytest.raises(ValueError):
            cbt.learn_online(bad_truths, bad_dets)
        assert cbt.to_json() == before
    for t, d in test[1:4]:
        cbt.learn_online(t, d)
        twin.learn_online(t, d)
    assert cbt == twin
    start = tuple(test[0][0][0])
    cbt.reset(start)
    twin.reset(start)
    assert [cbt.step(d) for _, d in test[4:10]] == [twin.step(d) for _, d in test[4:10]]
