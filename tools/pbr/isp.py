"""The phone between the light and the file, written for this tool: lens distortion (a remap of
the rendered light), a Bayer sensor (shot noise, read noise, saturation), demosaicking, a
veiling glare and a filmic tone curve, sharpening, luma, and a codec (H.264 through ffmpeg's
libx264, or JPEG through OpenCV's libjpeg). None of it is the project's renderers'.
"""

import math
import subprocess

import cv2
import numpy as np

from rig import distort_normalised, undistort_normalised


# --- lens ---------------------------------------------------------------------------------

def distortion_maps(camera, coeffs, canvas_origin_px, out_size):
    """For each output (distorted) pixel, where to sample the rendered undistorted canvas:
    x_u = undistort((x_d − c) / f)·f + c, shifted into the canvas. Pixels the lens folds over
    (no preimage) map outside the canvas and come out black."""
    w, h = out_size
    xs, ys = np.meshgrid(np.arange(w, dtype=float), np.arange(h, dtype=float))
    nd = np.stack([(xs - camera.principal_px[0]) / camera.focal_px,
                   (ys - camera.principal_px[1]) / camera.focal_px], axis=-1)
    nu = undistort_normalised(coeffs, nd)
    back = distort_normalised(coeffs, nu)
    folded = np.linalg.norm(back - nd, axis=-1) > 1e-6
    ux = nu[..., 0] * camera.focal_px + camera.principal_px[0] - canvas_origin_px[0]
    uy = nu[..., 1] * camera.focal_px + camera.principal_px[1] - canvas_origin_px[1]
    ux[folded] = -1e4
    uy[folded] = -1e4
    return ux.astype(np.float32), uy.astype(np.float32)


def canvas_for_distortion(camera, coeffs):
    """The undistorted canvas (origin in output pixels, size) that holds every preimage."""
    w, h = camera.width, camera.height
    border = np.concatenate([
        np.stack([np.arange(w), np.zeros(w)], 1), np.stack([np.arange(w), np.full(w, h - 1)], 1),
        np.stack([np.zeros(h), np.arange(h)], 1), np.stack([np.full(h, w - 1), np.arange(h)], 1)])
    nd = (border - camera.principal_px) / camera.focal_px
    nu = undistort_normalised(coeffs, nd)
    ok = np.linalg.norm(distort_normalised(coeffs, nu) - nd, axis=-1) < 1e-6
    pts = nu[ok] * camera.focal_px + camera.principal_px
    lo = np.floor(np.minimum(pts.min(0), [0, 0])) - 4
    hi = np.ceil(np.maximum(pts.max(0), [w - 1, h - 1])) + 4
    # Keep the principal point at the canvas centre (Blender renders about its centre).
    half = np.maximum(camera.principal_px - lo, hi - camera.principal_px)
    size = (2 * np.ceil(half)).astype(int)
    origin = camera.principal_px - (size - 1) / 2.0
    return origin, (int(size[0]), int(size[1]))


def remap(linear_rgb, maps):
    return cv2.remap(linear_rgb, maps[0], maps[1], interpolation=cv2.INTER_LANCZOS4,
                     borderMode=cv2.BORDER_CONSTANT, borderValue=0)


# --- sensor -------------------------------------------------------------------------------

def bayer_mosaic(rgb):
    """RGGB photosites from an RGB image (row 0: R G R G …, row 1: G B G B …)."""
    h, w, _ = rgb.shape
    out = np.empty((h, w), dtype=rgb.dtype)
    out[0::2, 0::2] = rgb[0::2, 0::2, 0]
    out[0::2, 1::2] = rgb[0::2, 1::2, 1]
    out[1::2, 0::2] = rgb[1::2, 0::2, 1]
    out[1::2, 1::2] = rgb[1::2, 1::2, 2]
    return out


def expose(linear_rgb, gain, full_well_e, read_noise_e, headroom, rng, noise=True):
    """Electrons at each photosite: Poisson(full_well · gain · light) + N(0, read noise),
    clipped at the well's capacity (`headroom` × full well), digitised to 16 bits; then
    demosaicked (OpenCV's edge-aware Bayer interpolation). Returns the relative signal
    (1.0 = `full_well_e` electrons) as RGB."""
    mosaic = bayer_mosaic(linear_rgb) * (gain * full_well_e)
    if noise:
        electrons = rng.poisson(np.maximum(mosaic, 0.0)).astype(np.float64)
        electrons += rng.normal(0.0, read_noise_e, size=mosaic.shape)
    else:
        electrons = mosaic
    capacity = headroom * full_well_e
    dn16 = np.clip(np.round(electrons / capacity * 65535.0), 0, 65535).astype(np.uint16)
    # OpenCV names Bayer patterns by the second row's first two sites: RGGB is "BayerBG".
    rgb16 = cv2.cvtColor(dn16, cv2.COLOR_BayerBG2RGB_EA)
    return rgb16.astype(np.float64) * (headroom / 65535.0)


# --- tone ---------------------------------------------------------------------------------

def hable(x):
    """Hable's filmic curve (the "Uncharted 2" operator): a toe and a soft shoulder."""
    a, b, c, d, e, f = 0.15, 0.50, 0.10, 0.20, 0.02, 0.30
    return ((x * (a * x + c * b) + d * e) / (x * (a * x + b) + d * f)) - e / f


def tone(x, exposure, white=6.0):
    """Scene-relative signal → display value in [0, 1] (then the sRGB transfer)."""
    y = hable(np.maximum(x, 0.0) * exposure) / hable(white)
    y = np.clip(y, 0.0, 1.0)
    return np.where(y <= 0.0031308, 12.92 * y, 1.055 * np.power(y, 1 / 2.4) - 0.055)


def solve_look(ink, paper, black_dn, white_dn):
    """The exposure and the black point that put the metered ink and paper signals at
    `black_dn` and `white_dn`: tone((ink + veil)·exposure) = black, tone((paper + veil)·exposure)
    = white. A positive veil is a veiling glare (light scattered uniformly into the image, as a
    lens flare lifts the blacks); a negative one the phone's black-point subtraction, which
    deepens blacks the curve's toe leaves grey."""
    def inv_tone(target, lo=1e-6, hi=1e3):
        for _ in range(200):
            mid = math.sqrt(lo * hi)
            if tone(mid, 1.0) < target:
                lo = mid
            else:
                hi = mid
        return math.sqrt(lo * hi)

    xb, xw = inv_tone(black_dn / 255.0), inv_tone(white_dn / 255.0)
    # (ink + v)/(paper + v) = xb/xw  →  v = (ratio·paper − ink)/(1 − ratio).
    ratio = xb / xw
    veil = (ratio * paper - ink) / (1.0 - ratio)
    exposure = xw / (paper + veil)
    return exposure, veil


def luma(rgb):
    """BT.709 luma of display-referred RGB."""
    return 0.2126 * rgb[..., 0] + 0.7152 * rgb[..., 1] + 0.0722 * rgb[..., 2]


def sharpen(y, amount, sigma_px):
    if amount <= 0.0:
        return y
    blurred = cv2.GaussianBlur(y, (0, 0), sigma_px)
    return y + amount * (y - blurred)


# --- codec --------------------------------------------------------------------------------

def encode_h264(frames_rgb8, fps, path, bitrate_bps, gop, bframes, preset):
    """The frames as a phone records them: H.264 (libx264) at a bitrate, 4:2:0, limited range."""
    h, w, _ = frames_rgb8[0].shape
    cmd = ["ffmpeg", "-hide_banner", "-loglevel", "error", "-y",
           "-f", "rawvideo", "-pix_fmt", "rgb24", "-s", f"{w}x{h}", "-r", f"{fps}", "-i", "-",
           "-c:v", "libx264", "-preset", preset, "-b:v", str(int(bitrate_bps)),
           "-maxrate", str(int(1.25 * bitrate_bps)), "-bufsize", str(int(2 * bitrate_bps)),
           "-g", str(gop), "-bf", str(bframes), "-pix_fmt", "yuv420p",
           "-colorspace", "bt709", "-color_primaries", "bt709", "-color_trc", "bt709",
           "-color_range", "tv", "-threads", "1", path]
    proc = subprocess.Popen(cmd, stdin=subprocess.PIPE)
    for f in frames_rgb8:
        proc.stdin.write(np.ascontiguousarray(f).tobytes())
    proc.stdin.close()
    if proc.wait() != 0:
        raise RuntimeError(f"ffmpeg could not encode {path}")


def decode_luma(path, w, h):
    """Each decoded frame's luma as a full-range 8-bit image (a player's expansion of the
    limited range)."""
    cmd = ["ffmpeg", "-hide_banner", "-loglevel", "error", "-i", path,
           "-f", "rawvideo", "-pix_fmt", "yuv420p", "-threads", "1", "-"]
    raw = subprocess.run(cmd, check=True, capture_output=True).stdout
    frame_bytes = w * h * 3 // 2
    out = []
    for k in range(len(raw) // frame_bytes):
        y = np.frombuffer(raw, dtype=np.uint8, count=w * h, offset=k * frame_bytes)
        y = (y.astype(np.float64) - 16.0) * (255.0 / 219.0)
        out.append(np.clip(np.round(y), 0, 255).astype(np.uint8).reshape(h, w))
    return out


def jpeg(y8, quality):
    ok, buf = cv2.imencode(".jpg", y8, [cv2.IMWRITE_JPEG_QUALITY, int(quality)])
    if not ok:
        raise RuntimeError("OpenCV could not encode a JPEG")
    return cv2.imdecode(buf, cv2.IMREAD_GRAYSCALE)


def write_png(path, y8):
    if not cv2.imwrite(path, y8):
        raise RuntimeError(f"could not write {path}")


def read_raw(path):
    """A rendered frame: 16-bit PNG, scene-linear, as RGB floats."""
    img = cv2.imread(path, cv2.IMREAD_UNCHANGED)
    if img is None:
        raise RuntimeError(f"{path}: Blender's frame could not be read")
    return img[..., ::-1].astype(np.float64) / 65535.0
