"""Every dtype and memory order: an array gives the field its .npy file gives (the CLI's
reader), bit for bit; views and byte orders; refused dtypes."""

import numpy as np
import pytest

import isoview

DTYPES = ["bool", "u1", "i1", "u2", "i2", "u4", "i4", "u8", "i8", "f2", "f4", "f8"]


def _volume(dtype):
    rng = np.random.default_rng(5)
    v = rng.integers(0, 100, size=(7, 6, 5))
    if dtype == "bool":
        return v > 50
    return v.astype(dtype)


@pytest.mark.parametrize("dtype", DTYPES)
@pytest.mark.parametrize("order", ["C", "F"])
def test_every_dtype_and_order_matches_its_npy_file(tmp_path, dtype, order):
    a = np.asarray(_volume(dtype), order=order)
    path = tmp_path / "v.npy"
    np.save(path, a)
    level = 0.5 if dtype == "bool" else 50.5
    mine = isoview.extract(a, level)
    theirs = isoview.extract(path, level, inside="above")
    assert len(mine.faces) > 0
    for x, y in zip(mine, theirs):
        assert x.tobytes() == y.tobytes()
    s = isoview.stats(path)
    assert s["dtype"] == np.lib.format.dtype_to_descr(a.dtype)


def test_views_and_byte_orders_are_read_as_their_values():
    base = np.random.default_rng(2).random((12, 10, 8))
    reference = isoview.extract(np.ascontiguousarray(base[::2, 1:, ::-1]), 0.5)
    for variant in (base[::2, 1:, ::-1],                                  # strided: copied
                    np.asfortranarray(base[::2, 1:, ::-1]),
                    base[::2, 1:, ::-1].astype(">f8")):                   # big-endian
        got = isoview.extract(variant, 0.5)
        assert got.verts.tobytes() == reference.verts.tobytes()


@pytest.mark.parametrize("dtype,hint", [
    ("c8", "complex samples are not supported"),
    ("O", "expected a boolean, integer or real dtype"),
    ("U3", "expected a boolean, integer or real dtype"),
])
def test_other_dtypes_are_refused_as_the_npy_reader_refuses_them(dtype, hint):
    a = np.zeros((3, 3, 3), dtype=dtype)
    with pytest.raises(ValueError, match=f"^the array: unsupported dtype .*{hint}"):
        isoview.render(a, 0.5, width=4, height=4)
