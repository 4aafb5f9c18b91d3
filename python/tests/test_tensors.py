"""Tensors and batches (issue 33 item 1) and the scoring domain (issue 32 item 1, Python side).

Batches must give, image by image, the bytes of single calls; layouts and kinds come back as they
went in. The sRGB curve and the srgb8 domain are checked against a transcription of IEC 61966-2-1
written here, and PSNR against its closed form on the coded values."""
import threading

import numpy as np
import pytest

import turbid
from turbid import _arrays

RNG = np.random.default_rng(5)
IMG = RNG.random((40, 56, 3), dtype=np.float32)
BATCH = np.stack([IMG, IMG[::-1].copy(), 0.5 * IMG, np.sqrt(IMG)])  # 4 x H x W x 3


def srgb_encode_ref(x):  # IEC 61966-2-1, float64
    x = np.asarray(x, np.float64)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.abs(x) ** (1 / 2.4) - 0.055)


def srgb_decode_ref(v):
    v = np.asarray(v, np.float64)
    return np.where(v <= 0.04045, v / 12.92, (np.abs(v + 0.055) / 1.055) ** 2.4)


def codes8(linear):
    """An 8-bit sRGB camera's codes of linear values (clip, curve, round)."""
    return np.rint(srgb_encode_ref(np.clip(np.nan_to_num(linear), 0, 1)) * 255).astype(np.uint8)


@pytest.mark.parametrize("method", ["clahe", "dcp", "simplified"])
def test_a_batch_is_its_images_one_by_one(method):
    out = turbid.enhance(BATCH, method)
    assert out.shape == BATCH.shape and out.dtype == np.float32
    for i in range(len(BATCH)):
        assert np.array_equal(out[i], turbid.enhance(BATCH[i], method)), i
    # Any number of leading dimensions; the result keeps them.
    nested = BATCH.reshape((2, 2) + IMG.shape)
    assert np.array_equal(turbid.enhance(nested, method).reshape(BATCH.shape), out)


def test_channel_axis_and_strides():
    want = turbid.enhance(BATCH, "clahe")
    chw = np.ascontiguousarray(BATCH.transpose(0, 3, 1, 2))   # N x C x H x W
    got = turbid.enhance(chw, "clahe", channel_axis=-3)
    assert got.shape == chw.shape and got.flags.c_contiguous
    assert np.array_equal(got, want.transpose(0, 3, 1, 2))
    assert np.array_equal(turbid.enhance(chw, "clahe", channel_axis=1), got)
    single = turbid.enhance(chw[0], "clahe", channel_axis=0)
    assert np.array_equal(single, want[0].transpose(2, 0, 1))
    # Negative strides, float64, float16 and a non-contiguous batch.
    assert np.array_equal(turbid.enhance(BATCH[::-1], "clahe"), want[::-1])
    assert np.array_equal(turbid.enhance(BATCH.astype(np.float64), "clahe"), want)
    half = BATCH.astype(np.float16)
    assert np.array_equal(turbid.enhance(half, "clahe"),
                          turbid.enhance(half.astype(np.float32), "clahe"))
    # Gray: H x W alone, N x H x W x 1 as a batch (the channel axis is kept).
    gray = np.ascontiguousarray(BATCH[..., 1:2])
    g = turbid.enhance(gray, "clahe")
    assert g.shape == gray.shape
    assert np.array_equal(g[2, :, :, 0], turbid.enhance(gray[2, :, :, 0], "clahe"))
    # Integer batches with an encoding.
    u8 = np.rint(BATCH * 255).astype(np.uint8)
    e8 = turbid.enhance(u8, "clahe", encoding="srgb")
    assert np.array_equal(e8[1], turbid.enhance(u8[1], "clahe", encoding="srgb"))
    u16 = (BATCH * 65535).astype(np.uint16)
    e16 = turbid.enhance(u16, "clahe", encoding="linear", channel_axis=-1)
    assert np.array_equal(e16[3], turbid.enhance(u16[3], "clahe", encoding="linear"))


def test_wrong_layouts_are_one_line():
    chw = np.ascontiguousarray(IMG.transpose(2, 0, 1))
    with pytest.raises(ValueError, match="channels first. pass channel_axis=-3"):
        turbid.enhance(chw, "clahe")
    with pytest.raises(ValueError, match="channels last. pass channel_axis=-1"):
        turbid.enhance(IMG, "clahe", channel_axis=-3)
    with pytest.raises(ValueError, match="out of range"):
        turbid.enhance(IMG, "clahe", channel_axis=5)
    with pytest.raises(TypeError, match="channel_axis"):
        turbid.enhance(IMG, "clahe", channel_axis="last")
    bad = BATCH.copy()
    bad[2, 3, 4, 0] = np.nan
    with pytest.raises(ValueError, match=r"image\[2\]"):  # the failing item is named
        turbid.enhance(bad, "clahe")
    with pytest.raises(ValueError, match=r"ref: batch shape \(3,\) differs"):
        turbid.score(BATCH, ref=BATCH[:3])


def test_torch_tensors_come_back_as_tensors_without_a_copy_in():
    torch = pytest.importorskip("torch")
    t = torch.from_numpy(BATCH).permute(0, 3, 1, 2)  # a channels-first view, not contiguous
    out = turbid.enhance(t, "clahe", channel_axis=1)
    assert isinstance(out, torch.Tensor) and out.shape == t.shape and out.is_contiguous()
    assert np.array_equal(out.numpy(), turbid.enhance(BATCH, "clahe").transpose(0, 3, 1, 2))
    one = torch.from_numpy(IMG)
    a, layout = _arrays.images(one, "image")
    assert np.shares_memory(a, one.numpy()) and layout.torch   # read in place
    assert isinstance(turbid.enhance(one, "clahe"), torch.Tensor)
    assert isinstance(turbid.enhance(one.double().requires_grad_(True), "clahe"), torch.Tensor)
    s = turbid.score(t, ref=t.flip(2), channel_axis=1)
    assert isinstance(s["psnr"], torch.Tensor) and s["psnr"].shape == (4,)
    assert isinstance(turbid.srgb_encode(one), torch.Tensor)


def test_batches_run_without_the_gil():
    big = np.stack([RNG.random((480, 640, 3), dtype=np.float32)] * 8)
    done = threading.Event()
    ticks = 0

    def work():
        for _ in range(2):
            turbid.enhance(big, "dcp")
        done.set()

    t = threading.Thread(target=work)
    t.start()
    while not done.is_set():
        ticks += 1
    t.join()
    assert ticks > 1000, ticks


def test_score_batch_is_its_images_one_by_one():
    ref = np.clip(BATCH * 1.1, 0, 1)
    got = turbid.score(BATCH, ref=ref, original=BATCH, metrics="all")
    for i in range(len(BATCH)):
        one = turbid.score(BATCH[i], ref=ref[i], original=BATCH[i], metrics="all")
        for name, value in one.items():
            assert got[name].shape == (4,)
            assert got[name][i] == value or (np.isnan(value) and np.isnan(got[name][i])), name


def test_score_domains_against_closed_forms():
    ref = np.clip(IMG * 0.8 + 0.05, 0, 1).astype(np.float32)
    assert set(turbid.SCORE_DOMAINS) == {"srgb8", "linear", "as_given"}
    # srgb8 (the default): PSNR of the 8-bit sRGB codes, range 255.
    a, b = codes8(IMG).astype(np.float64), codes8(ref).astype(np.float64)
    psnr8 = 10 * np.log10(255.0 ** 2 / np.mean((a - b) ** 2))
    assert abs(turbid.score(IMG, ref=ref)["psnr"] - psnr8) < 1e-9
    assert abs(turbid.score(IMG, ref=ref, domain="srgb8")["psnr"] - psnr8) < 1e-9
    # ... which is what the codes themselves score as given, and what uint8 arrays score.
    as_codes = turbid.score(codes8(IMG), ref=codes8(ref), domain="as_given")
    assert turbid.score(IMG, ref=ref) == as_codes
    assert turbid.score(codes8(IMG), ref=codes8(ref)) == as_codes
    # uint16 sRGB codes are rounded to 8 bits as the camera would.
    c16 = np.rint(srgb_encode_ref(IMG) * 65535).astype(np.uint16)
    assert turbid.score(c16, ref=codes8(ref)) == as_codes
    # linear: floats on [0, 1].
    psnr_lin = 10 * np.log10(1.0 / np.mean((IMG.astype(np.float64) - ref) ** 2))
    lin = turbid.score(IMG, ref=ref, domain="linear")
    assert abs(lin["psnr"] - psnr_lin) < 1e-9
    assert lin == turbid.score(IMG, ref=ref, domain="as_given")
    # Out-of-range values are clipped as a camera clips them; NaN is refused.
    assert turbid.score(IMG * 3 - 1, ref=ref)["psnr"] == turbid.score(
        np.clip(IMG * 3 - 1, 0, 1), ref=ref)["psnr"]
    nan = IMG.copy()
    nan[0, 0, 0] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        turbid.score(nan, ref=ref)
    with pytest.raises(ValueError, match="domain"):
        turbid.score(IMG, ref=ref, domain="srgb")
    # No-reference metrics read linear light whatever the domain.
    assert turbid.score(IMG, metrics="cnr") == turbid.score(IMG, metrics="cnr", domain="linear")


def test_srgb_helpers_against_the_standard():
    x = np.linspace(-0.1, 1.2, 2001, dtype=np.float32)
    np.testing.assert_allclose(turbid.srgb_encode(x), srgb_encode_ref(x), rtol=0, atol=2e-6)
    np.testing.assert_allclose(turbid.srgb_decode(x), srgb_decode_ref(x), rtol=0, atol=2e-6)
    assert np.array_equal(turbid.srgb_encode(IMG, dtype=np.uint8), codes8(IMG))
    c16 = turbid.srgb_encode(IMG, dtype="uint16")
    assert c16.dtype == np.uint16
    assert np.abs(c16.astype(int) - np.rint(srgb_encode_ref(IMG) * 65535)).max() <= 1
    codes = np.arange(256, dtype=np.uint8)
    np.testing.assert_allclose(turbid.srgb_decode(codes), srgb_decode_ref(codes / 255.0),
                               rtol=0, atol=1e-6)
    assert np.array_equal(turbid.srgb_encode(turbid.srgb_decode(codes), dtype=np.uint8), codes)
    # The curve read_image applies: a PNG written with codes reads back as their decoding.
    assert turbid.srgb_decode(BATCH).shape == BATCH.shape
    with pytest.raises(ValueError, match="dtype"):
        turbid.srgb_encode(IMG, dtype=np.int32)


def test_read_image_decodes_srgb_by_default_and_write_image_takes_codes(tmp_path):
    codes = np.rint(IMG * 255).astype(np.uint8)
    turbid.write_image(tmp_path / "c.png", codes)
    assert np.array_equal(np.rint(turbid.read_image(tmp_path / "c.png", encoding="linear") * 255),
                          codes.astype(np.float32))
    assert np.array_equal(turbid.read_image(tmp_path / "c.png"), turbid.srgb_decode(codes))
    c16 = (IMG * 65535).astype(np.uint16)
    turbid.write_image(tmp_path / "c16.png", c16)
    assert np.array_equal(np.rint(turbid.read_image(tmp_path / "c16.png", "linear") * 65535),
                          c16.astype(np.float32))
    with pytest.raises(ValueError, match="bit_depth=16"):
        turbid.write_image(tmp_path / "x.png", codes, bit_depth=16)
    # Floats are encoded with sRGB by default: written codes are the camera's.
    turbid.write_image(tmp_path / "f.png", IMG)
    assert np.array_equal(np.rint(turbid.read_image(tmp_path / "f.png", "linear") * 255),
                          codes8(IMG).astype(np.float32))
    chw = turbid.read_image(tmp_path / "f.png", channel_axis=-3)
    assert chw.shape == (3,) + IMG.shape[:2] and chw.flags.c_contiguous
    assert np.array_equal(chw, turbid.read_image(tmp_path / "f.png").transpose(2, 0, 1))


def test_from_arrays_takes_zero_depth_and_channels_first():
    depth = np.full(IMG.shape[:2], 2.0, np.float32)
    depth[:3] = 0.0  # TUM / ICL-NUIM: 0 = no measurement
    s = turbid.Scene.from_arrays(np.ascontiguousarray(IMG.transpose(2, 0, 1)), depth,
                                 50, 50, 28, 20, channel_axis=-3)
    assert np.isnan(s.depth[:3]).all() and (s.depth[3:] == 2.0).all()
    assert np.array_equal(s.image, IMG)
