"""visguide.lwpr.LWPR: bit-identical to the Rust crate on the same samples
(tests/reference.json), the reference module's vocabulary, validation and round trips."""

import copy
import pickle
import threading

import numpy as np
import pytest
from conftest import CRATE, bytes_digest

from visguide.lwpr import LWPR


def make(case):
    if case == "cross_2d":
        model = LWPR(2, 1)
        model.init_D = 50 * np.eye(2)
        model.init_alpha = 250 * np.ones([2, 2])
    else:
        model = LWPR(3, 2)
        model.init_D = 20 * np.eye(3)
        model.init_alpha = 100 * np.ones([3, 3])
        model.diag_only = False
        model.meta = True
        model.norm_in = [1.0, 2.0, 0.5]
        model.norm_out = np.array([1.0, 3.0])
    return model


CASES = ["cross_2d", "full_meta_3d"]


def check_equal_to_reference(model, ref):
    assert model.num_rfs == ref["num_rfs"]
    assert bytes_digest(model.to_bytes()) == ref["binary"]
    for q, p in zip(ref["queries"], ref["predictions"]):
        # Exact equality of floats: bit-identical to the Rust model.
        assert model.predict(q, 0.001).tolist() == p["y"]
        assert model.predict(np.array(q)).tolist() == p["y0"]
        y, conf = model.predict_conf(q, 0.001)
        assert (y.tolist(), conf.tolist()) == (p["conf_y"], p["conf"])
        y, jac = model.predict_J(q, 0.001)
        assert (y.tolist(), jac.tolist()) == (p["jacobian_y"], p["jacobian"])


@pytest.mark.parametrize("case", CASES)
def test_update_is_bit_identical_to_the_rust_crate(reference, case):
    ref = reference["lwpr"][case]
    model = make(case)
    learning = [model.update(np.array(x), np.array(y)).tolist() for x, y in zip(ref["x"], ref["y"])]
    assert learning == ref["y_learning"]
    assert model.n_data == len(ref["x"])
    check_equal_to_reference(model, ref)


@pytest.mark.parametrize("case", CASES)
def test_update_batch_is_bit_identical_to_the_rust_crate(reference, case):
    ref = reference["lwpr"][case]
    model = make(case)
    learning = model.update_batch(np.array(ref["x"]), np.array(ref["y"]))
    assert learning.shape == (len(ref["x"]), model.nOut)
    assert learning.tolist() == ref["y_learning"]
    check_equal_to_reference(model, ref)
    qs = np.array(ref["queries"])
    assert model.predict_batch(qs, 0.001).tolist() == [p["y"] for p in ref["predictions"]]


def test_update_batch_in_pieces_equals_one_batch(reference):
    ref = reference["lwpr"]["cross_2d"]
    x, y = np.array(ref["x"]), np.array(ref["y"])
    a, b = make("cross_2d"), make("cross_2d")
    a.update_batch(x, y)
    b.update_batch(x[:150], y[:150])
    b.update_batch(x[150:], y[150:])
    assert a == b


def test_non_contiguous_and_integer_inputs_work(reference):
    ref = reference["lwpr"]["cross_2d"]
    x, y = np.array(ref["x"]), np.array(ref["y"])
    a, b = make("cross_2d"), make("cross_2d")
    a.update_batch(x, y)
    # Fortran order and a strided view of a wider array hold the same values.
    wide = np.zeros((len(x), 4))
    wide[:, ::2] = x
    b.update_batch(wide[:, ::2], np.asfortranarray(y))
    assert a == b
    assert a.predict([0, 0]).tolist() == a.predict(np.array([0.0, 0.0])).tolist()
    assert a.predict(np.array([0, 0], dtype=np.int32)).tolist() == a.predict([0.0, 0.0]).tolist()


def trained():
    model = LWPR(2, 1)
    model.init_D = 50 * np.eye(2)
    rng = np.random.default_rng(7)
    x = rng.uniform(-1, 1, (300, 2))
    model.update_batch(x, np.sin(3 * x[:, :1]) * x[:, 1:])
    return model


@pytest.mark.parametrize(
    "x, y",
    [
        ([np.nan, 0.0], [0.0]),
        ([0.0, np.inf], [0.0]),
        ([0.0, 0.0], [np.nan]),
        ([0.0], [0.0]),
        ([0.0, 0.0, 0.0], [0.0]),
        ([0.0, 0.0], [0.0, 1.0]),
    ],
)
def test_bad_samples_are_refused_without_changing_the_model(x, y):
    model = trained()
    before = model.to_bytes()
    with pytest.raises(ValueError):
        model.update(x, y)
    with pytest.raises(ValueError):
        model.update_batch(np.array([[0.1, 0.2], x] if len(x) == 2 else [x]), np.array([[0.0], y] if len(y) == 1 else [y]))
    assert model.to_bytes() == before


def test_a_nan_anywhere_in_a_batch_changes_nothing():
    model = trained()
    before = model.to_bytes()
    x = np.random.default_rng(1).uniform(-1, 1, (50, 2))
    y = x[:, :1].copy()
    y[49, 0] = np.nan
    with pytest.raises(ValueError, match="row 49"):
        model.update_batch(x, y)
    with pytest.raises(ValueError, match="rows"):
        model.update_batch(x, y[:10])
    assert model.to_bytes() == before


@pytest.mark.parametrize(
    "where, value",
    [("X", 1e31), ("X", -1e31), ("Y", 1e31), ("Y", -1e31), ("X / norm_in", 1e21), ("Y / norm_out", 1e21)],
)
@pytest.mark.parametrize("row", [0, 1, 9])
def test_a_value_beyond_the_bound_anywhere_in_a_batch_changes_nothing(where, value, row):
    """A finite value beyond LWPR's bound of 1e30 (raw, or once normalised) in any row of a
    batch is refused before any row is learned: the batch used to learn the rows before it,
    then raise."""
    model = trained()
    model.norm_in = [1e-10, 1.0]
    model.norm_out = [1e-10]
    before = model.to_bytes()
    twin = LWPR.from_bytes(before)
    x = np.random.default_rng(2).uniform(-1, 1, (10, 2))
    y = x[:, :1].copy()
    (x if where.startswith("X") else y)[row, 0] = value
    with pytest.raises(ValueError) as refused:
        model.update_batch(x, y)
    assert model.to_bytes() == before
    assert f"row {row}" in str(refused.value)
    with pytest.raises(ValueError):
        model.update(x[row], y[row])
    assert model.to_bytes() == before
    # The model learns on as the twin that never saw the refused batch.
    good_x, good_y = x[:row], y[:row]
    assert model.update_batch(good_x, good_y).tolist() == twin.update_batch(good_x, good_y).tolist()
    assert model == twin


def test_bad_queries_are_value_errors():
    model = trained()
    for call in [model.predict, model.predict_conf, model.predict_J]:
        with pytest.raises(ValueError):
            call([np.nan, 0.0])
        with pytest.raises(ValueError):
            call([0.0, 0.0, 0.0])
        with pytest.raises(ValueError):
            call([0.0, 0.0], float("nan"))
    with pytest.raises(ValueError):
        model.predict_batch(np.zeros((3, 3)))
    with pytest.raises(TypeError):
        model.predict(np.zeros((2, 2)))


def test_meta_parameters_are_attributes():
    model = LWPR(2, 1)
    assert (model.nIn, model.nOut, model.n_data) == (2, 1, 0)
    assert model.init_D.tolist() == (25 * np.eye(2)).tolist()
    assert model.init_M.tolist() == (5 * np.eye(2)).tolist()
    assert model.init_alpha.tolist() == (50 * np.ones((2, 2))).tolist()
    assert (model.w_gen, model.w_prune, model.init_lambda, model.final_lambda) == (0.1, 1.0, 0.999, 0.99999)
    assert (model.tau_lambda, model.init_S2, model.add_threshold, model.penalty) == (0.9999, 1e-10, 0.5, 1e-6)
    assert (model.diag_only, model.update_D, model.meta, model.meta_rate) == (True, True, False, 250.0)
    assert model.kernel == "Gaussian" and model.prune_rule == "reference_c" and model.arithmetic == "fast"
    assert model.norm_in.tolist() == [1.0, 1.0] and model.norm_out.tolist() == [1.0]
    for name, value in [
        ("w_gen", 0.2),
        ("w_prune", 0.9),
        ("init_lambda", 0.99),
        ("final_lambda", 0.9999),
        ("tau_lambda", 0.99),
        ("init_S2", 1e-8),
        ("add_threshold", 0.4),
        ("penalty", 1e-5),
        ("meta_rate", 100.0),
        ("diag_only", False),
        ("update_D", False),
        ("meta", True),
        ("kernel", "BiSquare"),
        ("prune_rule", "reference_c"),
        ("arithmetic", "reference"),
    ]:
        setattr(model, name, value)
        assert getattr(model, name) == value, name
    model.init_D = [[4.0, 1.0], [1.0, 9.0]]
    assert model.init_D.tolist() == [[4.0, 1.0], [1.0, 9.0]]
    m = model.init_M
    assert np.allclose(m.T @ m, model.init_D) and m[1, 0] == 0.0


@pytest.mark.parametrize(
    "name, value",
    [
        ("w_gen", 1.5),
        ("w_gen", float("nan")),
        ("init_lambda", 0.0),
        ("penalty", -1.0),
        ("meta_rate", 0.0),
        ("init_D", [[1.0, 2.0], [0.0, 1.0]]),
        ("init_D", [[1.0, 0.0], [0.0, -1.0]]),
        ("init_D", np.eye(3)),
        ("init_alpha", np.zeros((2, 2))),
        ("norm_in", [1.0]),
        ("norm_in", [1.0, 0.0]),
        ("norm_out", [np.nan]),
        ("kernel", "Cauchy"),
        ("prune_rule", "random"),
        ("arithmetic", "exact"),
    ],
)
def test_invalid_meta_parameters_are_refused_without_changing_the_model(name, value):
    model = trained()
    before = model.to_bytes()
    with pytest.raises(ValueError):
        setattr(model, name, value)
    assert model.to_bytes() == before


def test_off_diagonal_init_D_needs_a_full_metric():
    model = LWPR(2, 1)
    with pytest.raises(ValueError, match="diagonal"):
        model.init_D = [[4.0, 1.0], [1.0, 9.0]]
    model.diag_only = False
    model.init_D = [[4.0, 1.0], [1.0, 9.0]]


def test_setting_a_parameter_keeps_what_was_learned():
    model = trained()
    rfs, n = model.num_rfs, model.n_data
    q = [0.3, -0.2]
    y = model.predict(q).tolist()
    model.w_gen = 0.3
    assert (model.num_rfs, model.n_data, model.predict(q).tolist()) == (rfs, n, y)
    assert model.w_gen == 0.3


def test_receptive_fields():
    model = trained()
    k = model.num_rfs[0]
    assert k > 0
    assert model.rf_center(0, k - 1).shape == (2,)
    assert model.rf_D(0, 0).shape == (2, 2)
    with pytest.raises(ValueError):
        model.rf_center(0, k)
    with pytest.raises(ValueError):
        model.rf_D(1, 0)


@pytest.mark.parametrize("suffix", [".json", ".bin"])
def test_save_and_load_round_trip(tmp_path, suffix):
    model = trained()
    path = tmp_path / ("model" + suffix)
    model.save(path)
    for loaded in [LWPR.load(path), LWPR(str(path)), LWPR(path)]:
        assert loaded == model
        assert loaded.predict([0.1, 0.2]).tolist() == model.predict([0.1, 0.2]).tolist()


def test_file_errors(tmp_path):
    with pytest.raises(OSError):
        LWPR.load(tmp_path / "missing.bin")
    with pytest.raises(OSError):
        trained().save(tmp_path / "no" / "such" / "dir" / "m.bin")
    bad = tmp_path / "bad.bin"
    bad.write_bytes(b"not a model")
    with pytest.raises(ValueError):
        LWPR.load(bad)
    data = bytearray(trained().to_bytes())
    data[40] ^= 1
    with pytest.raises(ValueError, match="checksum"):
        LWPR.from_bytes(bytes(data))
    with pytest.raises(ValueError):
        LWPR(2)
    with pytest.raises(ValueError):
        LWPR(0, 1)


def test_pickle_and_copy_round_trip():
    model = trained()
    for clone in [pickle.loads(pickle.dumps(model)), copy.deepcopy(model), LWPR.from_bytes(model.to_bytes())]:
        assert clone == model and clone is not model
        # Training continues identically.
        clone.update([0.5, 0.5], [0.1])
        m2 = LWPR.from_bytes(model.to_bytes())
        m2.update([0.5, 0.5], [0.1])
        assert clone == m2
    assert "LWPR(n_in=2" in repr(model)


def test_pickling_while_another_thread_trains_is_a_runtime_error():
    """``update_batch`` holds the model while it trains without the GIL: pickling it from
    another thread meanwhile raises ``RuntimeError`` (already borrowed), as any other call on
    it does. It used to panic (``pyo3_runtime.PanicException``, not an ``Exception``)."""
    model = LWPR(2, 1)
    rng = np.random.default_rng(0)
    x = rng.uniform(-1.0, 1.0, size=(300_000, 2))
    y = np.sin(3.0 * x[:, :1])
    worker = threading.Thread(target=model.update_batch, args=(x, y))
    worker.start()
    refused = 0
    try:
        while worker.is_alive():
            try:
                pickle.dumps(model)
            except RuntimeError:
                refused += 1
    finally:
        worker.join()
    assert refused > 0
    assert model.n_data == len(x)
    assert pickle.loads(pickle.dumps(model)) == model


# --- XML model files of the reference library --------------------------------------------------

REFERENCE_XML = CRATE.parent / "lwpr" / "tests" / "data" / "reference_setting_a.xml"


@pytest.mark.parametrize("case", CASES)
def test_xml_is_the_rust_crates_file(reference, case):
    ref = reference["lwpr"][case]
    model = make(case)
    model.update_batch(np.array(ref["x"]), np.array(ref["y"]))
    assert bytes_digest(model.to_xml().encode()) == ref["xml"]
    back = LWPR.from_xml(model.to_xml())
    assert back == model
    check_equal_to_reference(back, ref)


@pytest.mark.parametrize("case", CASES)
def test_write_XML_and_read_XML_round_trip_exactly(tmp_path, case):
    model = trained() if case == "cross_2d" else make(case)
    if case != "cross_2d":
        rng = np.random.default_rng(4)
        x = rng.uniform(-1, 1, (300, 3))
        model.update_batch(x, np.stack([np.sin(x[:, 0]), x[:, 1] * x[:, 2]], axis=1))
    path = tmp_path / "model.xml"
    model.write_XML(path)
    assert path.read_text().startswith("<?xml version='1.0' encoding='US-ASCII' ?>\n<LWPR ")
    for loaded in [LWPR.read_XML(path), LWPR.read_XML(str(path)), LWPR(path), LWPR.load(path)]:
        assert loaded == model
    # Training goes on identically from the file.
    loaded = LWPR.read_XML(path)
    x = np.full((1, model.nIn), 0.25)
    y = np.full((1, model.nOut), 0.5)
    assert loaded.update_batch(x, y).tolist() == model.update_batch(x, y).tolist()
    assert loaded == model
    assert not list(tmp_path.glob(".*tmp*"))


def test_reference_library_xml_file_predicts_like_the_rust_crate(reference):
    ref = reference["lwpr"]["reference_xml"]
    model = LWPR.read_XML(REFERENCE_XML)
    assert model.num_rfs == ref["num_rfs"] and model.n_data == ref["n_data"]
    assert model.arithmetic == "reference" and model.prune_rule == "reference_c"
    got = [model.predict(q, 0.001).tolist() for q in ref["queries"]]
    assert got == ref["predictions"]
    assert LWPR(str(REFERENCE_XML)) == model


def test_file_errors_name_the_file(tmp_path):
    """Every model-file error names its file, once (the crate's I/O errors did not: "i/o error:
    No such file or directory" for whichever of several files was missing; its write errors
    now do, and were then named twice)."""
    missing = tmp_path / "missing-model.bin"
    bad = tmp_path / "corrupt-model.json"
    bad.write_text("{not json")
    nowhere = tmp_path / "no" / "dir" / "out-model.xml"
    for call, name, error in [
        (lambda: LWPR.load(missing), missing.name, OSError),
        (lambda: LWPR(str(missing)), missing.name, OSError),
        (lambda: LWPR.read_XML(missing), missing.name, OSError),
        (lambda: LWPR.load(bad), bad.name, ValueError),
        (lambda: trained().save(nowhere), nowhere.name, OSError),
        (lambda: trained().write_XML(nowhere), nowhere.name, OSError),
    ]:
        with pytest.raises(error, match=name) as caught:
            call()
        assert str(caught.value).count(name) == 1, str(caught.value)


def test_xml_errors(tmp_path):
    model = trained()
    text = model.to_xml()
    with pytest.raises(OSError):
        LWPR.read_XML(tmp_path / "missing.xml")
    with pytest.raises(OSError):
        model.write_XML(tmp_path / "no" / "such" / "dir" / "m.xml")
    assert not (tmp_path / "no").exists()
    bad = {
        "truncated": text[: len(text) // 2],
        "NaN": text.replace("<scalar name='w_gen'>", "<scalar name='w_gen'> NaN </scalar><!--", 1).replace(
            "</scalar>\n\t<scalar name='w_prune'>", " -->\n\t<scalar name='w_prune'>", 1
        ),
        "wrong nIn": text.replace("nIn='2'", "nIn='3'", 1),
        "wrong length": text.replace("<vector name='mean_x' length='2'>", "<vector name='mean_x' length='3'>", 1),
        "not XML": "LWPR",
        "empty": "",
    }
    for what, t in bad.items():
        assert t != text, what
        with pytest.raises(ValueError):
            LWPR.from_xml(t)
        path = tmp_path / "bad.xml"
        path.write_text(t)
        with pytest.raises(ValueError):
            LWPR.read_XML(path)
