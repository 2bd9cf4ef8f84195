"""A small ctypes binding to LittleCMS 2: write ICC profiles, read them back, transform colours.

Defines
-------
- :func:`library`: the loaded ``liblcms2`` (the system's, else the copy Pillow's wheel bundles),
  or a :class:`~dreamprint_gui.core.errors.DreamPrintError` saying how to install it.
- :class:`ProfileWriter`: an ICC profile built tag by tag with LittleCMS's own writer
  (``cmsCreateProfilePlaceholder``, ``cmsWriteTag``, ``cmsSaveProfileToMem``): header, text,
  XYZ, matrix and measurement tags, and 3-D lookup tables as ``[curves, CLUT, curves]``
  pipelines, which LittleCMS writes as ``lut16Type`` in a version 2 profile and as
  ``lutAtoBType`` / ``lutBtoAType`` in a version 4 profile (``cmsio1.c``'s type decision).
- :func:`transform`: colours through a profile and LittleCMS's CMM in double precision
  (``cmsCreateTransform`` with ``TYPE_*_DBL``), to a D50 CIELAB (``cmsCreateLab4Profile``) or
  from it; used to check a written profile, as any colour-managed application reads it.
- :func:`read_tag_pipeline_eval`: evaluate one LUT tag (e.g. ``gamt``) of a profile.

Why a binding of our own: no maintained Python package writes ICC LUT profiles. Pillow's
ImageCms wraps LittleCMS but only *creates* built-in profiles (sRGB, Lab, XYZ) and transforms
8-bit images; ``iccdev`` (the ICC's RefIccMAX, alpha, one wheel per Python) reads and validates
but writes only by way of its XML tools; ``colour-science`` reads no ICC at all. LittleCMS
itself is the most used CMM (GIMP, Krita, darktable, Scribus, Inkscape) and writes every tag
needed; this module only declares its C functions (the API of ``lcms2.h``, 2.9 or newer).
"""

from __future__ import annotations

import ctypes
import ctypes.util
import glob
import sys
from functools import lru_cache
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dreamprint_gui.core.errors import DreamPrintError

__all__ = ["library", "ProfileWriter", "transform", "read_tag_pipeline_eval", "sig",
           "profile_info", "INTENT_CODES"]

# ICC rendering intents as numbered in the header and in cmsCreateTransform.
INTENT_CODES = {"perceptual": 0, "relative": 1, "saturation": 2, "absolute": 3}
_AT_END = 1  # cmsAT_END
# Pixel formats of lcms2.h: FLOAT_SH(1) | COLORSPACE_SH(pt) | CHANNELS_SH(n) | BYTES_SH(0).
_PT = {"RGB": 4, "Lab": 10, "XYZ": 9, "GRAY": 3}


def _dbl_format(space: str, channels: int) -> int:
    return (1 << 22) | (_PT[space] << 16) | (channels << 3)


def sig(text: str) -> int:
    """The 32-bit signature of a four-character ICC tag or type name."""
    b = text.encode("ascii")
    if len(b) != 4:
        raise ValueError(f"ICC signatures have four characters: {text!r}")
    return int.from_bytes(b, "big")


class _XYZ(ctypes.Structure):
    _fields_ = [("X", ctypes.c_double), ("Y", ctypes.c_double), ("Z", ctypes.c_double)]


class _Measurement(ctypes.Structure):  # cmsICCMeasurementConditions
    _fields_ = [("Observer", ctypes.c_uint32), ("Backing", _XYZ),
                ("Geometry", ctypes.c_uint32), ("Flare", ctypes.c_double),
                ("IlluminantType", ctypes.c_uint32)]


def _candidates() -> list[str]:
    names = []
    found = ctypes.util.find_library("lcms2")
    if found:
        names.append(found)
    names += ["liblcms2.so.2", "liblcms2.2.dylib", "lcms2.dll", "liblcms2-2.dll"]
    try:  # Pillow's wheels bundle LittleCMS beside the package (Linux, macOS)
        import PIL

        root = Path(PIL.__file__).resolve().parent
        for pattern in ("../pillow.libs/liblcms2*", "../Pillow.libs/liblcms2*",
                        ".dylibs/liblcms2*", "../PIL.libs/liblcms2*"):
            names += sorted(glob.glob(str(root / pattern)))
    except ImportError:
        pass
    return names


@lru_cache(maxsize=1)
def library() -> ctypes.CDLL:
    """liblcms2, with the signatures of the functions used here declared."""
    lib = None
    for name in _candidates():
        try:
            lib = ctypes.CDLL(name)
            break
        except OSError:
            continue
    if lib is None:
        how = ("apt-get install liblcms2-2" if sys.platform.startswith("linux")
               else "install Little CMS 2 (e.g. brew install little-cms2)")
        raise DreamPrintError(f"writing ICC profiles needs the Little CMS 2 library ({how})")
    p, u32, dbl, i32 = ctypes.c_void_p, ctypes.c_uint32, ctypes.c_double, ctypes.c_int
    decl = {
        "cmsGetEncodedCMMversion": ([], i32),
        "cmsCreateProfilePlaceholder": ([p], p),
        "cmsCloseProfile": ([p], i32),
        "cmsSetProfileVersion": ([p, dbl], None),
        "cmsGetProfileVersion": ([p], dbl),
        "cmsSetDeviceClass": ([p, u32], None),
        "cmsSetColorSpace": ([p, u32], None),
        "cmsSetPCS": ([p, u32], None),
        "cmsSetHeaderRenderingIntent": ([p, u32], None),
        "cmsGetDeviceClass": ([p], u32),
        "cmsGetColorSpace": ([p], u32),
        "cmsGetPCS": ([p], u32),
        "cmsMLUalloc": ([p, u32], p),
        "cmsMLUsetASCII": ([p, ctypes.c_char_p, ctypes.c_char_p, ctypes.c_char_p], i32),
        "cmsMLUfree": ([p], None),
        "cmsMLUgetASCII": ([p, ctypes.c_char_p, ctypes.c_char_p, ctypes.c_char_p, u32], u32),
        "cmsWriteTag": ([p, u32, p], i32),
        "cmsLinkTag": ([p, u32, u32], i32),
        "cmsReadTag": ([p, u32], p),
        "cmsIsTag": ([p, u32], i32),
        "cmsSaveProfileToMem": ([p, p, ctypes.POINTER(u32)], i32),
        "cmsOpenProfileFromMem": ([p, u32], p),
        "cmsCreateLab4Profile": ([p], p),
        "cmsPipelineAlloc": ([p, u32, u32], p),
        "cmsPipelineFree": ([p], None),
        "cmsPipelineInsertStage": ([p, i32, p], i32),
        "cmsPipelineEvalFloat": ([p, p, p], None),
        "cmsPipelineInputChannels": ([p], u32),
        "cmsPipelineOutputChannels": ([p], u32),
        "cmsStageAllocCLut16bit": ([p, u32, u32, u32, p], p),
        "cmsStageAllocToneCurves": ([p, u32, p], p),
        "cmsCreateTransform": ([p, u32, p, u32, u32, u32], p),
        "cmsDoTransform": ([p, p, p, u32], None),
        "cmsDeleteTransform": ([p], None),
    }
    for fname, (args, res) in decl.items():
        f = getattr(lib, fname)
        f.argtypes = args
        f.restype = res
    if lib.cmsGetEncodedCMMversion() < 2090:
        raise DreamPrintError("Little CMS 2.9 or newer is needed to write ICC profiles "
                              f"(found {lib.cmsGetEncodedCMMversion()})")
    return lib


def _check(ok, what: str) -> None:
    if not ok:
        raise DreamPrintError(f"Little CMS could not {what}")


class ProfileWriter:
    """An ICC profile under construction in LittleCMS (see the module doc)."""

    def __init__(self, version: float, device_class: str, colour_space: str, pcs: str) -> None:
        self._lib = lib = library()
        self._h = lib.cmsCreateProfilePlaceholder(None)
        _check(self._h, "create a profile")
        lib.cmsSetProfileVersion(self._h, float(version))
        lib.cmsSetDeviceClass(self._h, sig(device_class))
        lib.cmsSetColorSpace(self._h, sig(colour_space))
        lib.cmsSetPCS(self._h, sig(pcs))

    def close(self) -> None:
        if self._h:
            self._lib.cmsCloseProfile(self._h)
            self._h = None

    def __enter__(self) -> ProfileWriter:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def header(self, rendering_intent: int = 0) -> None:
        """The header's rendering intent (the intent a CMM uses when none is asked)."""
        self._lib.cmsSetHeaderRenderingIntent(self._h, rendering_intent)

    def text(self, tag: str, text: str) -> None:
        """A text tag (``desc``, ``cprt``...): textDescription / text in v2, mluc in v4."""
        lib = self._lib
        mlu = lib.cmsMLUalloc(None, 1)
        try:
            _check(lib.cmsMLUsetASCII(mlu, b"en", b"US",
                                      text.encode("ascii", "replace")), "store a text")
            _check(lib.cmsWriteTag(self._h, sig(tag), mlu), f"write the {tag} tag")
        finally:
            lib.cmsMLUfree(mlu)

    def xyz(self, tag: str, xyz: ArrayLike) -> None:
        v = _XYZ(*[float(x) for x in np.asarray(xyz, dtype=np.float64)])
        _check(self._lib.cmsWriteTag(self._h, sig(tag), ctypes.byref(v)), f"write {tag}")

    def signature(self, tag: str, value: str) -> None:
        """A signature tag (``tech``: e.g. ``ijet``, ink jet printer)."""
        v = ctypes.c_uint32(sig(value))
        _check(self._lib.cmsWriteTag(self._h, sig(tag), ctypes.byref(v)), f"write {tag}")

    def matrix(self, tag: str, m: ArrayLike) -> None:
        """A 3x3 matrix tag (``chad``: s15Fixed16ArrayType), row-major."""
        a = (ctypes.c_double * 9)(*np.asarray(m, dtype=np.float64).reshape(9).tolist())
        _check(self._lib.cmsWriteTag(self._h, sig(tag), a), f"write {tag}")

    def measurement(self, observer: int, backing: ArrayLike, geometry: int, flare: float,
                    illuminant_type: int) -> None:
        """The ``meas`` tag (ICC.1 10.13): observer 1 = CIE 1931, geometry 0 = unknown,
        1 = 0/45 or 45/0, 2 = 0/d or d/0; illuminant 1 = D50, 2 = D65."""
        m = _Measurement(observer, _XYZ(*np.asarray(backing, float).tolist()), geometry,
                         float(flare), illuminant_type)
        _check(self._lib.cmsWriteTag(self._h, sig("meas"), ctypes.byref(m)), "write meas")

    def clut(self, tag: str, table: NDArray[np.uint16]) -> None:
        """A LUT tag from a 16-bit table ``(n, ..., n, out)`` (n nodes per input, first input
        varying slowest: the ICC CLUT order), as identity curves, CLUT, identity curves."""
        lib = self._lib
        table = np.ascontiguousarray(table, dtype=np.uint16)
        n_in = table.ndim - 1
        n_out = table.shape[-1]
        grid = table.shape[0]
        lut = lib.cmsPipelineAlloc(None, n_in, n_out)
        _check(lut, "allocate a pipeline")
        try:
            stages = [lib.cmsStageAllocToneCurves(None, n_in, None),
                      lib.cmsStageAllocCLut16bit(None, grid, n_in, n_out,
                                                 table.ctypes.data_as(ctypes.c_void_p)),
                      lib.cmsStageAllocToneCurves(None, n_out, None)]
            for s in stages:
                _check(s and lib.cmsPipelineInsertStage(lut, _AT_END, s), "build a pipeline")
            _check(lib.cmsWriteTag(self._h, sig(tag), lut), f"write the {tag} tag")
        finally:
            lib.cmsPipelineFree(lut)

    def link(self, tag: str, to: str) -> None:
        """Tag ``tag`` sharing ``to``'s data (one copy in the file; ICC.1 7.3.5 allows tags to
        share data)."""
        _check(self._lib.cmsLinkTag(self._h, sig(tag), sig(to)), f"link {tag} to {to}")

    def to_bytes(self) -> bytes:
        """The profile as LittleCMS serialises it (header, tag table, tags; MD5 profile ID
        for version 4)."""
        lib = self._lib
        size = ctypes.c_uint32(0)
        _check(lib.cmsSaveProfileToMem(self._h, None, ctypes.byref(size)), "size the profile")
        buf = ctypes.create_string_buffer(size.value)
        _check(lib.cmsSaveProfileToMem(self._h, buf, ctypes.byref(size)), "write the profile")
        return buf.raw[:size.value]


class _Opened:
    def __init__(self, data: bytes) -> None:
        self.lib = library()
        self.data = ctypes.create_string_buffer(data, len(data))
        self.h = self.lib.cmsOpenProfileFromMem(self.data, len(data))
        if not self.h:
            raise DreamPrintError("Little CMS cannot read this ICC profile")

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.lib.cmsCloseProfile(self.h)


def profile_info(data: bytes) -> dict:
    """Header facts and the tags present, as LittleCMS reads them."""
    with _Opened(data) as p:
        lib = p.lib

        def s(v: int) -> str:
            return v.to_bytes(4, "big").decode("latin-1")

        out = {"version": round(lib.cmsGetProfileVersion(p.h), 2),
               "class": s(lib.cmsGetDeviceClass(p.h)), "colour_space": s(lib.cmsGetColorSpace(p.h)),
               "pcs": s(lib.cmsGetPCS(p.h))}
        mlu = lib.cmsReadTag(p.h, sig("desc"))
        if mlu:
            buf = ctypes.create_string_buffer(512)
            lib.cmsMLUgetASCII(mlu, b"en", b"US", buf, 512)
            out["description"] = buf.value.decode("ascii", "replace")
        return out


def transform(data: bytes, values: ArrayLike, intent: str, direction: str = "to_lab",
              space: str = "RGB") -> NDArray[np.float64]:
    """Colours through the profile ``data`` by LittleCMS's CMM (double precision): device
    values (N, 3) in [0, 1] to D50 CIELAB (``to_lab``), or CIELAB to device (``from_lab``),
    with an ICC intent name of :data:`INTENT_CODES`."""
    lib = library()
    v = np.ascontiguousarray(np.asarray(values, dtype=np.float64).reshape(-1, 3))
    out = np.empty_like(v)
    with _Opened(data) as p:
        lab = lib.cmsCreateLab4Profile(None)
        try:
            src, dst = (p.h, lab) if direction == "to_lab" else (lab, p.h)
            fin, fout = ((_dbl_format(space, 3), _dbl_format("Lab", 3)) if direction == "to_lab"
                         else (_dbl_format("Lab", 3), _dbl_format(space, 3)))
            xf = lib.cmsCreateTransform(src, fin, dst, fout, INTENT_CODES[intent], 0)
            if not xf:
                raise DreamPrintError(f"Little CMS cannot build a {intent} transform "
                                      "with this profile")
            try:
                # RGB as doubles is 0..1 in Little CMS; CIELAB as doubles is plain L*, a*, b*.
                lib.cmsDoTransform(xf, v.ctypes.data_as(ctypes.c_void_p),
                                   out.ctypes.data_as(ctypes.c_void_p), len(v))
            finally:
                lib.cmsDeleteTransform(xf)
        finally:
            lib.cmsCloseProfile(lab)
    return out


def read_tag_pipeline_eval(data: bytes, tag: str, values: ArrayLike) -> NDArray[np.float64]:
    """Evaluate a LUT tag of the profile on ``values``: each channel as a fraction 0..1 of the
    tag's own 16-bit encoding (``cmsReadTag``'s pipeline, before the v2/v4 Lab normalisation
    LittleCMS adds for transforms)."""
    v = np.asarray(values, dtype=np.float32)
    with _Opened(data) as p:
        lut = p.lib.cmsReadTag(p.h, sig(tag))
        if not lut:
            raise DreamPrintError(f"the profile has no {tag} tag")
        n_out = p.lib.cmsPipelineOutputChannels(lut)
        out = np.empty((len(v), n_out), dtype=np.float32)
        for i in range(len(v)):
            row = np.ascontiguousarray(v[i])
            p.lib.cmsPipelineEvalFloat(row.ctypes.data_as(ctypes.c_void_p),
                                       out[i].ctypes.data_as(ctypes.c_void_p), lut)
    return out.astype(np.float64)
