"""Out-of-core path: chunked phase, windowed variance sums, file sources, memory budget."""

from __future__ import annotations

import numpy as np
import pytest

import allanite
from allanite import _core
from allanite.errors import InputError
from allanite.variance.chunked import ArrayRecord, BinaryRecord, TextRecord, npy_record, open_large
from allanite.variance.outofcore import avar_large, parse_memory
from allanite.variance.phase_store import build_phase_store

WINDOWED = ["overlapping", "standard", "hadamard", "standard_hadamard"]


def _record(n: int = 20_000, c: int = 3, seed: int = 5) -> np.ndarray:
    rng = np.random.default_rng(seed)
    # a large bias and a drift: the compensated passes must still agree bit for bit
    return 1e3 + np.cumsum(rng.standard_normal((n, c)), axis=0) * 1e-3 + rng.standard_normal((n, c))


@pytest.mark.parametrize("input_kind", ["rate", "increment", "angle"])
@pytest.mark.parametrize("dtype", [np.float64, np.float32, np.int16, np.int32, np.int64])
def test_chunked_phase_equals_core_phase_bitwise(input_kind, dtype):
    x = (_record(3001) * 10).astype(dtype)
    expected = _core.phase(x, input_kind)
    for chunk_rows in (1, 7, 1024, 3001, 10_000):
        for budget in (None, 1):  # in memory, and forced into a temporary file
            with build_phase_store(
                ArrayRecord(x), input_kind, chunk_rows=chunk_rows, max_memory_bytes=budget
            ) as store:
                assert store.in_memory == (budget is None)
                got = store.read(0, np.empty((store.rows, store.channels)))
                assert np.array_equal(got, expected), (chunk_rows, budget)


def test_partial_sums_split_on_blocks_are_exact():
    rng = np.random.default_rng(1)
    x = np.cumsum(rng.standard_normal((50_000, 2)), axis=0)
    m = 37
    n = x.shape[0] - 2 * m
    whole = np.zeros((2, 2))
    _core.diff_square_sums([x[:n], x[m : m + n], x[2 * m : 2 * m + n]], 1, n, whole)
    block = int(_core.SUM_BLOCK)
    for chunk in (block, 3 * block, 17 * block):
        state = np.zeros((2, 2))
        for j0 in range(0, n, chunk):
            c = min(chunk, n - j0)
            taps = [np.ascontiguousarray(x[j0 + i * m : j0 + i * m + c]) for i in range(3)]
            _core.diff_square_sums(taps, 1, c, state)
        assert np.array_equal(state, whole)
    var = (whole[:, 0] + whole[:, 1]) / (2.0 * m * m * n)
    assert np.array_equal(var, _core.variance(x, [m], "overlapping", 1)[0])


@pytest.mark.parametrize("kind", WINDOWED)
def test_out_of_core_equals_in_memory_for_threads_and_chunks(kind, tmp_path):
    x = _record(40_000)
    expected = allanite.avar(x, fs=50.0, kind=kind, alpha=0, threads=1)
    for threads in (1, 2):
        for limit in ("300kB", "1.5MB"):
            got = avar_large(
                x, fs=50.0, kind=kind, alpha=0, threads=threads, memory_limit=limit, tmpdir=tmp_path
            )
            assert got.meta["phase_in_memory"] is False
            assert np.array_equal(got.var, expected.var), (threads, limit)
            assert np.array_equal(got.edf, expected.edf)
    assert list(tmp_path.iterdir()) == []  # temporary phase files are deleted


@pytest.mark.parametrize("kind", [*WINDOWED, "modified", "total", "time"])
def test_in_memory_results_identical_across_thread_counts(kind):
    x = _record(6000)
    one = allanite.avar(x, fs=10.0, kind=kind, alpha=0, threads=1)
    two = allanite.avar(x, fs=10.0, kind=kind, alpha=0, threads=2)
    large = avar_large(x, fs=10.0, kind=kind, alpha=0, threads=2, chunk_rows=1000)
    assert np.array_equal(one.var, two.var)
    assert np.array_equal(one.var, large.var)


def test_angle_input_out_of_core(tmp_path):
    x = np.cumsum(_record(30_000, c=1)[:, 0])
    expected = allanite.avar(x, fs=100.0, input="angle", alpha=0)
    got = avar_large(x, fs=100.0, input="angle", alpha=0, memory_limit="200kB", tmpdir=tmp_path)
    assert got.var.ndim == 1
    assert np.array_equal(got.var, expected.var)


def test_noise_identification_out_of_core_matches_when_it_fits():
    from allanite.variance.edf import identify_alpha
    from allanite.variance.outofcore import variance_from_store

    x = _record(4000, c=2)
    factors = np.array([1, 2, 4, 8, 16, 64, 256, 1024, 1999], dtype=np.int64)
    with build_phase_store(ArrayRecord(x), "rate", chunk_rows=999, max_memory_bytes=1) as store:
        _, alphas = variance_from_store(
            store, factors, "overlapping", threads=2, alpha_rows=10**6, identify="frequency"
        )
    expected = identify_alpha(_core.phase(x, "rate"), factors, "overlapping", data="frequency")
    assert np.array_equal(alphas, expected)


@pytest.mark.parametrize("byteorder", ["<", ">"])
@pytest.mark.parametrize("layout", ["interleaved", "planar"])
def test_raw_binary_file(tmp_path, byteorder, layout):
    x = _record(12_345).astype(np.float32)
    path = tmp_path / "rec.bin"
    header = b"HDR!" * 4
    data = x if layout == "interleaved" else np.asfortranarray(x)
    raw = data.astype(x.dtype.newbyteorder(byteorder)).tobytes(
        order="C" if layout == "interleaved" else "F"
    )
    path.write_bytes(header + raw)
    rec = BinaryRecord.open(
        path, "float32", n_channels=3, byteorder=byteorder, offset=len(header), layout=layout
    )
    assert rec.n_samples == 12_345
    blocks = np.concatenate([b.copy() for b in rec.chunks(1000)])
    assert np.array_equal(blocks, x)
    expected = allanite.avar(x, fs=200.0, alpha=0)
    got = avar_large(
        path,
        fs=200.0,
        alpha=0,
        memory_limit="256kB",
        dtype="float32",
        n_channels=3,
        byteorder=byteorder,
        offset=len(header),
        layout=layout,
    )
    assert np.array_equal(got.var, expected.var)


@pytest.mark.parametrize("order", ["C", "F"])
def test_npy_file_read_in_chunks(tmp_path, order):
    x = np.asarray(_record(5000).astype(np.int32), order=order)
    path = tmp_path / "rec.npy"
    np.save(path, x)
    rec = npy_record(path)
    assert (rec.n_samples, rec.n_channels) == (5000, 3)
    assert np.array_equal(np.concatenate([b.copy() for b in rec.chunks(333)]), x)
    got = avar_large(path, fs=1.0, alpha=0, kind="hadamard", memory_limit="128kB")
    assert np.array_equal(got.var, allanite.avar(x, fs=1.0, alpha=0, kind="hadamard").var)


def test_text_file_read_in_chunks(tmp_path):
    x = _record(2500)
    path = tmp_path / "rec.csv"
    lines = ["time,gx,gy,gz", "# a comment line"]
    lines += [f"{k / 100:.2f},{a!r},{b!r},{c!r}" for k, (a, b, c) in enumerate(x.tolist())]
    path.write_text("\n".join(lines) + "\n")
    rec = open_large(path, columns=(1, 2, 3), skiprows=1)
    assert isinstance(rec, TextRecord)
    assert rec.n_channels == 3
    got = avar_large(rec, fs=100.0, alpha=0, memory_limit="64kB", chunk_rows=256)
    assert np.array_equal(got.var, allanite.avar(x, fs=100.0, alpha=0).var)


def test_text_file_bad_line_names_the_line(tmp_path):
    path = tmp_path / "bad.txt"
    path.write_text("1.0\n2.0\nabc\n4.0\n")
    rec = TextRecord.open(path)
    with pytest.raises(InputError, match="line 3"):
        list(rec.chunks(10))


def test_progress_callback_reports_both_stages(tmp_path):
    x = _record(20_000, c=1)[:, 0]
    calls: list[tuple[str, int, int]] = []
    avar_large(
        x,
        fs=1.0,
        alpha=0,
        memory_limit="200kB",
        chunk_rows=4096,
        tmpdir=tmp_path,
        progress=lambda stage, done, total: calls.append((stage, done, total)),
    )
    stages = [c[0] for c in calls]
    variance_done = [c[1] for c in calls if c[0] == "variance"]
    assert variance_done == list(range(1, len(variance_done) + 1))  # one call per tau
    assert stages[0] == "phase"
    assert stages[-1] == "variance"
    assert stages.index("variance") == stages.count("phase")
    for stage in ("phase", "variance"):
        done = [c[1] for c in calls if c[0] == stage]
        total = {c[2] for c in calls if c[0] == stage}
        assert done == sorted(done)
        assert len(total) == 1
        assert done[-1] == total.pop()


def test_in_memory_progress_and_result_unchanged():
    x = _record(8000, c=1)[:, 0]
    seen: list[int] = []
    got = avar_large(
        x, fs=1.0, alpha=0, progress=lambda s, d, t: seen.append(d) if s == "variance" else None
    )
    expected = allanite.avar(x, fs=1.0, alpha=0)
    assert np.array_equal(got.var, expected.var)
    assert seen[-1] == expected.tau.size


@pytest.mark.parametrize(
    ("text", "value"),
    [
        ("1GB", 10**9),
        ("512MiB", 512 * 2**20),
        ("2e9", 2 * 10**9),
        (" 1.5 gb ", 15 * 10**8),
        (3e6, 3 * 10**6),
    ],
)
def test_parse_memory(text, value):
    assert parse_memory(text) == value


@pytest.mark.parametrize("bad", ["lots", "1 parsec", "10", -5, float("nan")])
def test_parse_memory_rejects(bad):
    with pytest.raises(ValueError, match="memory_limit"):
        parse_memory(bad)


def test_memory_limit_type_error():
    with pytest.raises(TypeError, match="memory_limit"):
        parse_memory(True)


def test_kinds_needing_memory_are_refused_out_of_core(tmp_path):
    with pytest.raises(ValueError, match="raise memory_limit"):
        avar_large(
            _record(20_000, c=1),
            fs=1.0,
            kind="modified",
            alpha=0,
            memory_limit="100kB",
            tmpdir=tmp_path,
        )
    assert list(tmp_path.iterdir()) == []


def test_raw_file_size_mismatch_is_an_input_error(tmp_path):
    path = tmp_path / "odd.bin"
    path.write_bytes(b"\0" * 10)
    with pytest.raises(InputError, match="whole number"):
        BinaryRecord.open(path, "float32", n_channels=1)
    with pytest.raises(ValueError, match="dtype="):
        open_large(path)
    with pytest.raises(TypeError, match="not supported"):
        BinaryRecord.open(path, "complex64")


def test_non_finite_sample_is_named(tmp_path):
    x = _record(5000, c=1)[:, 0]
    x[4321] = np.nan
    with pytest.raises(ValueError, match="sample 4321"):
        avar_large(x, fs=1.0, alpha=0, memory_limit="64kB", chunk_rows=1000, tmpdir=tmp_path)
    assert list(tmp_path.iterdir()) == []


def test_avar_delegates_memory_limit_progress_and_fast(tmp_path, monkeypatch):
    monkeypatch.setattr("tempfile.tempdir", str(tmp_path))
    x = _record(30_000, c=1)[:, 0]
    plain = allanite.avar(x, fs=10.0, alpha=0)
    stages = set()
    big = allanite.avar(
        x, fs=10.0, alpha=0, memory_limit="100kB", progress=lambda s, d, t: stages.add(s)
    )
    assert big.meta["phase_in_memory"] is False
    assert np.array_equal(big.var, plain.var)
    assert stages == {"phase", "variance"}
    assert allanite.avar(x, fs=10.0, alpha=0, fast=True).meta["fast_q"] == 16
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("channels", [1, 2, 3, 5])
@pytest.mark.parametrize("kind", ["overlapping", "standard_hadamard"])
def test_kernel_paths_match_reference_at_large_m(channels, kind):
    """Every channel-count specialisation (1-4 and the generic one) against the numpy oracle."""
    from allanite.variance import oracle

    x = _record(9000, c=channels, seed=channels)
    phase = _core.phase(x, "rate")
    top = int(_core.max_m(kind, phase.shape[0]))
    factors = np.array([1, 3, 1000, top - 1, top], dtype=np.int64)
    got = _core.variance(phase, factors, kind, 2)
    oracle_kernel = getattr(oracle, f"{kind}_variance")
    for c in range(channels):
        ref = [oracle_kernel(phase[:, c], int(m)) for m in factors]
        np.testing.assert_allclose(got[:, c], ref, rtol=1e-12)


def test_bounded_identification_in_memory_uses_the_decimated_head():
    from allanite.variance.edf import identify_alpha
    from allanite.variance.outofcore import _identify

    x = _record(6000, c=2)
    phase = _core.phase(x, "rate")
    factors = np.array([1, 4, 32, 512], dtype=np.int64)
    from allanite.variance.edf import cap_few_point_alpha

    got = _identify(phase, factors, "overlapping", "frequency", 700)
    heads = [np.ascontiguousarray(phase[::m][:700]) for m in factors.tolist()]
    per_factor = np.array(
        [identify_alpha(h, np.array([1]), "overlapping", data="frequency")[0] for h in heads]
    )
    points = np.array([h.shape[0] - 1 for h in heads])
    assert np.array_equal(got, cap_few_point_alpha(per_factor, factors, points))
    # unbounded: exactly avar's identification
    full = _identify(phase, factors, "overlapping", "frequency", None)
    assert np.array_equal(full, identify_alpha(phase, factors, "overlapping", data="frequency"))


@pytest.mark.parametrize("kind", ["overlapping", "hadamard"])
@pytest.mark.parametrize("channels", [1, 3])
def test_tau_blocked_pass_equals_one_factor_at_a_time(kind, channels):
    """Small factors share tiled passes; each must equal its own single pass bit for bit."""
    x = _record(40_000, c=channels, seed=11)
    phase = _core.phase(x, "rate")
    top = int(_core.max_m(kind, phase.shape[0]))
    factors = np.unique(np.r_[1:40, 1023, 1024, 1025, 8191, 8192, 8193, 12_000, top])
    alone = np.vstack([_core.variance(phase, [int(m)], kind, 1) for m in factors])
    for threads in (1, 2, 3):
        assert np.array_equal(_core.variance(phase, factors, kind, threads), alone)


@pytest.mark.parametrize("extra", [0, 4321])
def test_chunked_phase_equals_core_phase_across_phase_blocks(extra):
    """Records of several PHASE_BLOCK blocks (a partial last one or none), read in chunks that
    end inside blocks, on block edges, or hold several blocks: the same bits as _core.phase
    on any number of threads."""
    block = int(_core.PHASE_BLOCK)
    for channels in (1, 2):  # one: four blocks side by side in a vector; two: one by one
        x = _record(4 * block + extra, c=channels)
        expected = _core.phase(x, "rate", threads=1)
        assert np.array_equal(_core.phase(x, "rate", threads=2), expected)
        for chunk_rows in (7919, block, block + 1, 3 * block):
            with build_phase_store(
                ArrayRecord(x), "rate", chunk_rows=chunk_rows, max_memory_bytes=None
            ) as store:
                got = store.read(0, np.empty((store.rows, store.channels)))
                assert np.array_equal(got, expected), (channels, chunk_rows)


def test_stream_sums_state_errors_name_the_fix():
    """A state of the wrong shape or a read-only one is refused before any work, with the
    shape to create."""
    x = np.ones((10, 2))
    zeros = np.zeros(2)
    with pytest.raises(ValueError, match="SUM_LANES_STATE"):
        _core.stream_sums(x, 0, np.zeros((2, 2)), zeros, zeros)
    state = np.zeros((2, _core.SUM_LANES_STATE))
    state.flags.writeable = False
    with pytest.raises(ValueError, match="writable"):
        _core.stream_sums(x, 0, state, zeros, zeros)
    state = np.zeros((2, _core.SUM_LANES_STATE))
    assert _core.stream_sums(x, 0, state, zeros, zeros).shape == (0, 2)  # no block completed
    assert np.array_equal(_core.stream_sums_value(state), [10.0, 10.0])
