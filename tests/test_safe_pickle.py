"""The restricted unpickler: what it lets through, what it refuses, and that refused code never runs."""

from __future__ import annotations

import builtins
import copyreg
import io
import os
import pickle
import pickletools
import resource
import subprocess
import zipfile
from pathlib import Path

import numpy as np
import pytest
from conftest import shared_path
from numpy.lib import format as npy_format

from socialaff_sim.errors import DataError, UnsafePickleError

try:
    from numpy._core.multiarray import _reconstruct  # NumPy >= 2
except ImportError:  # pragma: no cover - NumPy 1.x
    from numpy.core.multiarray import _reconstruct
from socialaff_sim.data.safe_pickle import (
    NUMPY_ARRAY_GLOBALS,
    ROS_TIME_GLOBALS,
    RosTime,
    restricted_load,
    restricted_loads,
)


# -- payloads whose unpickling would run code ---------------------------------------------------------
class _OsSystem:
    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self):
        return (os.system, (f"touch {self.marker}",))


class _Eval:
    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self):
        return (builtins.eval, (f"open({str(self.marker)!r}, 'w').close()",))


class _Popen:
    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self):
        return (subprocess.Popen, (["touch", str(self.marker)],))


PAYLOADS = {"os.system": (_OsSystem, ("posix.system", "nt.system")),
            # protocol 2 writes Python 2 names: __builtin__.eval
            "builtins.eval": (_Eval, ("builtins.eval", "__builtin__.eval")),
            "subprocess.Popen": (_Popen, ("subprocess.Popen", "commands.Popen"))}


@pytest.mark.parametrize("kind", sorted(PAYLOADS))
@pytest.mark.parametrize("protocol", [2, 4])
def test_malicious_reduce_is_refused_and_never_runs(tmp_path: Path, kind: str, protocol: int) -> None:
    cls, forbidden = PAYLOADS[kind]
    marker = tmp_path / "pwned"
    # Hidden inside an otherwise legitimate dict, as an attacker would. (Protocol 2 pickles array
    # bytes through _codecs.encode, itself refused, so there the legitimate part holds no array.)
    legit = np.zeros((3, 34, 3)) if protocol >= 3 else "pose"
    data = pickle.dumps({"pose_giver": legit, "evil": cls(marker)}, protocol=protocol)
    path = tmp_path / "motion_normal_0.pkl"
    path.write_bytes(data)
    with pytest.raises(UnsafePickleError) as info:
        restricted_load(path, allowed=NUMPY_ARRAY_GLOBALS, expect=dict)
    message = str(info.value)
    assert any(f"forbidden global {name}" in message for name in forbidden), message
    assert str(path) in message
    assert not marker.exists(), "the forbidden callable ran"


def test_the_payload_is_real_for_an_unrestricted_unpickler(tmp_path: Path) -> None:
    # Control: the same stream does run code under plain pickle, so the test above can fail.
    marker = tmp_path / "ran"
    obj = pickle.loads(pickle.dumps(_Eval(marker)))  # noqa: S301 - deliberate, harmless payload
    assert obj is None and marker.exists()


def test_malicious_object_inside_an_object_array_is_refused(tmp_path: Path, fake_rospy: type) -> None:
    marker = tmp_path / "pwned"
    arr = np.empty(2, dtype=object)
    arr[:] = [fake_rospy(1, 2), _Eval(marker)]
    with pytest.raises(UnsafePickleError, match="builtins.eval"):
        restricted_loads(pickle.dumps(arr, protocol=4), allowed=ROS_TIME_GLOBALS, expect=np.ndarray, source="x.npy")
    assert not marker.exists()


def test_extension_codes_also_go_through_the_allow_list(tmp_path: Path) -> None:
    code = 0x7FFF_FF01
    module = "posix" if os.name == "posix" else "nt"
    copyreg.add_extension(module, "system", code)
    try:
        data = pickle.dumps(os.system, protocol=2)
    finally:
        copyreg.remove_extension(module, "system", code)
    assert any(op.name.startswith("EXT") for op, _, _ in pickletools.genops(data))
    copyreg.add_extension(module, "system", code)
    try:
        with pytest.raises(UnsafePickleError, match=f"{module}.system"):
            restricted_loads(data, allowed=NUMPY_ARRAY_GLOBALS, expect=dict, source="ext.pkl")
    finally:
        copyreg.remove_extension(module, "system", code)


def test_persistent_ids_are_refused() -> None:
    class _Pers(pickle.Pickler):
        def persistent_id(self, obj):
            return "secret" if isinstance(obj, str) and obj == "x" else None

    buf = io.BytesIO()
    _Pers(buf, protocol=2).dump({"a": "x"})
    with pytest.raises(UnsafePickleError, match="persistent"):
        restricted_loads(buf.getvalue(), allowed=NUMPY_ARRAY_GLOBALS, expect=dict, source="p.pkl")


@pytest.mark.parametrize(
    "stream, forbidden",
    [
        (b"cbuiltins\ngetattr\n(cbuiltins\ndict\nVget\ntR.", "builtins.getattr"),
        (b"cnumpy\nload\n(Vx\ntR.", "numpy.load"),
        (b"cnumpy.core.numeric\n_frombuffer\n.", "numpy.core.numeric._frombuffer"),
        (b"(cos\nsystem\nVtrue\no.", "os.system"),  # OBJ opcode
        (b"(Vtrue\nios\nsystem\n.", "os.system"),  # INST opcode
    ],
)
def test_crafted_streams_name_the_forbidden_global(stream: bytes, forbidden: str) -> None:
    with pytest.raises(UnsafePickleError, match=forbidden.replace(".", r"\.")):
        restricted_loads(stream, allowed=NUMPY_ARRAY_GLOBALS, expect=dict, source="crafted.pkl")


@pytest.mark.parametrize("protocol", [3, 4])
def test_dicts_of_arrays_and_scalars_round_trip(protocol: int, rng: np.random.Generator) -> None:
    original = {
        "pose": rng.normal(size=(5, 34, 3)),
        "ints": np.arange(6, dtype=np.int32).reshape(2, 3),
        "fortran": np.asfortranarray(rng.normal(size=(3, 4))),
        "scalar": np.float64(1.25),
        "count": np.int64(7),
    }
    loaded = restricted_loads(pickle.dumps(original, protocol=protocol), allowed=NUMPY_ARRAY_GLOBALS, expect=dict)
    assert sorted(loaded) == sorted(original)
    for key, value in original.items():
        np.testing.assert_array_equal(loaded[key], value)
        assert loaded[key].dtype == value.dtype


def test_protocol_5_array_buffers_are_not_on_the_allow_list() -> None:
    data = pickle.dumps({"a": np.arange(3.0)}, protocol=5)
    with pytest.raises(UnsafePickleError, match="_frombuffer"):
        restricted_loads(data, allowed=NUMPY_ARRAY_GLOBALS, expect=dict)


def test_wrong_top_level_type_is_rejected() -> None:
    data = pickle.dumps([np.zeros(3)], protocol=4)
    with pytest.raises(DataError, match="expected a pickled dict at top level, found list"):
        restricted_loads(data, allowed=NUMPY_ARRAY_GLOBALS, expect=dict, source="list.pkl")


@pytest.mark.parametrize("cut", [1, 40, -2])
def test_truncated_or_garbage_streams_are_data_errors(cut: int) -> None:
    data = pickle.dumps({"a": np.arange(10.0)}, protocol=4)
    with pytest.raises(DataError, match="not a readable pickle") as info:
        restricted_loads(data[:cut], allowed=NUMPY_ARRAY_GLOBALS, expect=dict, source="cut.pkl")
    assert not isinstance(info.value, UnsafePickleError)
    assert "cut.pkl" in str(info.value)


def test_missing_file_is_a_data_error(tmp_path: Path) -> None:
    with pytest.raises(DataError, match="cannot read"):
        restricted_load(tmp_path / "absent.pkl", allowed=NUMPY_ARRAY_GLOBALS, expect=dict)


# -- ROS time stamps ------------------------------------------------------------------------------------
def test_ros_time_stamps_become_plain_values(fake_rospy: type) -> None:
    stamps = np.empty(3, dtype=object)
    stamps[:] = [fake_rospy(1656508537, 848842220), fake_rospy(1656508537, 973480602), fake_rospy(1656508538, 0)]
    data = pickle.dumps(stamps, protocol=4)  # what np.save writes for object arrays
    assert b"rospy.rostime" in data
    loaded = restricted_loads(data, allowed=ROS_TIME_GLOBALS, expect=np.ndarray)
    assert [(t.secs, t.nsecs) for t in loaded] == [(1656508537, 848842220), (1656508537, 973480602), (1656508538, 0)]
    assert all(type(t) is RosTime for t in loaded)
    assert loaded[0].to_sec() == pytest.approx(1656508537.848842220, abs=1e-6)


def test_ros_time_is_refused_by_the_array_only_allow_list(fake_rospy: type) -> None:
    data = pickle.dumps(np.array([fake_rospy(1, 2)], dtype=object), protocol=4)
    with pytest.raises(UnsafePickleError, match="rospy.rostime.Time"):
        restricted_loads(data, allowed=NUMPY_ARRAY_GLOBALS, expect=np.ndarray)


@pytest.mark.parametrize("state", [[1], ["1", 2], [1, 2_000_000_000], [True, 0]])
def test_malformed_ros_time_state_names_the_file(fake_rospy: type, state: list) -> None:
    t = fake_rospy(0, 0)
    t.__getstate__ = lambda: state  # type: ignore[method-assign]
    data = pickle.dumps(np.array([t], dtype=object), protocol=4)
    with pytest.raises(DataError, match="ROS time state") as info:
        restricted_loads(data, allowed=ROS_TIME_GLOBALS, expect=np.ndarray, source="stamps.npy")
    assert "stamps.npy" in str(info.value)


def test_real_nuisi_stamps_match_an_independent_opcode_decode() -> None:
    path = shared_path("nuisi_v1", "handshake2_agent2.bag.npz")
    with zipfile.ZipFile(path) as zf, zf.open("arr_1.npy") as fh:
        npy_format.read_magic(fh)
        shape, _, dtype = npy_format.read_array_header_1_0(fh)
        payload = fh.read()
    assert dtype == np.dtype(object)
    loaded = restricted_loads(payload, allowed=ROS_TIME_GLOBALS, expect=np.ndarray, source=path)
    # Reference: the integer operands of the stream, read without unpickling anything.
    ints = [arg for op, arg, _ in pickletools.genops(payload) if op.name in ("BININT", "BININT1", "BININT2")]
    pairs = np.array(ints[-2 * shape[0]:]).reshape(-1, 2)
    assert loaded.shape == shape
    np.testing.assert_array_equal([(t.secs, t.nsecs) for t in loaded], pairs)


def test_real_handover_pickle_loads_as_dict_of_float_arrays() -> None:
    path = shared_path("handover_h2h", "motion_normal_0.pkl")
    rec = restricted_load(path, allowed=NUMPY_ARRAY_GLOBALS, expect=dict)
    assert set(rec) == {"pose_giver", "pose_receiver", "pose_object", "quat_object"}
    T = rec["pose_giver"].shape[0]
    assert rec["pose_receiver"].shape == (T, 34, 3) and rec["quat_object"].shape == (T, 4)
    assert all(v.dtype == np.float64 for v in rec.values())


# -- resource caps --------------------------------------------------------------------------------------
def _reconstruct_stream(shape: tuple[int, ...], state: tuple | None = None) -> bytes:
    """A pickle calling numpy's _reconstruct(ndarray, shape, 'b') (and BUILD with ``state``), by hand."""
    class Crafted:
        def __reduce__(self):
            args = (_reconstruct, (np.ndarray, shape, b"b"))
            return args if state is None else (*args, state)

    return pickle.dumps(Crafted(), protocol=4)


@pytest.mark.parametrize("make_stream", [
    lambda: _reconstruct_stream((15 << 30,)),                                             # 15 GiB at construction
    lambda: _reconstruct_stream((0,), (1, (15 << 30,), np.dtype(object), False, [])),     # 120 GiB object array
    lambda: _reconstruct_stream((0,), (1, (1 << 31,), np.dtype("f8"), False, b"\0" * 8)),  # 16 GiB from 8 bytes
    lambda: _reconstruct_stream((0,), (1, (1 << 20,), np.dtype("f8"), False, b"\0" * 8)),  # 8 MiB: over 64x + 1 MiB
])
def test_a_short_pickle_cannot_allocate_gigabytes(make_stream) -> None:
    stream = make_stream()
    assert len(stream) < 200
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    with pytest.raises(DataError, match="exceeds the limit"):
        restricted_loads(stream, allowed=NUMPY_ARRAY_GLOBALS, expect=np.ndarray)
    grown_mib = (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before) / 1024
    assert grown_mib < 64, grown_mib


def test_memo_index_beyond_the_stream_is_refused_before_running() -> None:
    stream = b"\x80\x04}r\xff\xff\xff\xff."  # EMPTY_DICT, LONG_BINPUT 2**32 - 1: the C unpickler would size its memo
    with pytest.raises(DataError, match="memo index 4294967295"):
        restricted_loads(stream, allowed=NUMPY_ARRAY_GLOBALS, expect=dict)


def test_arrays_within_the_caps_still_load_as_plain_ndarrays(rng: np.random.Generator) -> None:
    data = {"a": rng.normal(size=(300, 34, 3)), "b": np.arange(5)}
    out = restricted_loads(pickle.dumps(data, protocol=4), allowed=NUMPY_ARRAY_GLOBALS, expect=dict)
    assert all(type(v) is np.ndarray for v in out.values())
    np.testing.assert_array_equal(out["a"], data["a"])


def test_array_subclasses_are_refused() -> None:
    class Crafted:
        def __reduce__(self):
            return (_reconstruct, (np.ma.MaskedArray, (1,), b"b"))

    stream = pickle.dumps(Crafted(), protocol=4)
    with pytest.raises(UnsafePickleError):
        restricted_loads(stream, allowed=NUMPY_ARRAY_GLOBALS, expect=np.ndarray)


# -- a matrix of crafted streams: dangerous globals × every opcode that resolves a global ----------------
DANGEROUS = [
    "os.system", "posix.system", "nt.system", "os.popen", "os.execv", "os.remove", "subprocess.Popen",
    "subprocess.call", "subprocess.check_output", "builtins.eval", "builtins.exec", "builtins.compile",
    "builtins.open", "builtins.getattr", "builtins.setattr", "builtins.__import__", "builtins.globals",
    "builtins.print", "__builtin__.eval", "importlib.import_module", "shutil.rmtree", "pickle.loads",
    "_pickle.loads", "marshal.loads", "types.FunctionType", "types.CodeType", "ctypes.CDLL", "socket.socket",
    "webbrowser.open", "numpy.load", "numpy.fromfile", "numpy.testing._private.utils.runstring",
    "numpy.ctypeslib.load_library", "pty.spawn", "code.interact",
]


def _short_unicode(text: str) -> bytes:
    raw = text.encode()
    return b"\x8c" + bytes([len(raw)]) + raw


def _stream(opcode: str, dotted: str) -> bytes:
    """A hand-written stream that resolves ``dotted`` through ``opcode`` and calls it with no arguments."""
    module, name = dotted.rsplit(".", 1)
    m, n = module.encode(), name.encode()
    if opcode == "GLOBAL":  # protocol 0: c<module>\n<name>\n, then () and REDUCE
        return b"c" + m + b"\n" + n + b"\n)R."
    if opcode == "STACK_GLOBAL":  # protocol 4
        return b"\x80\x04" + _short_unicode(module) + _short_unicode(name) + b"\x93)R."
    if opcode == "INST":  # protocol 0: MARK, INST <module>\n<name>\n calls it with the marked items
        return b"(i" + m + b"\n" + n + b"\n."
    if opcode == "OBJ":  # protocol 1: MARK, GLOBAL, OBJ calls it with the items after it
        return b"(c" + m + b"\n" + n + b"\no."
    raise AssertionError(opcode)


@pytest.mark.parametrize("opcode", ["GLOBAL", "STACK_GLOBAL", "INST", "OBJ"])
@pytest.mark.parametrize("dotted", DANGEROUS)
def test_crafted_stream_matrix_is_refused_by_both_allow_lists(opcode: str, dotted: str) -> None:
    stream = _stream(opcode, dotted)
    assert any(op.name == opcode for op, _, _ in pickletools.genops(stream))  # the stream is what it claims
    for allowed in (NUMPY_ARRAY_GLOBALS, ROS_TIME_GLOBALS):
        with pytest.raises(UnsafePickleError, match=f"forbidden global {dotted.replace('.', '[.]')}"):
            restricted_loads(stream, allowed=allowed, expect=object)
