#!/usr/bin/env python3
"""Compares a split frame with native, both x11grab bgr0 grabs of the same size.

  compare_foveae.py --size WxH --eyes N NATIVE.raw SPLIT.raw

The foveae are the default ones (512x360 of a 1200x1080 eye, centred in each eye), computed from
that definition as tests/e2e/harness/fovea.h does, not from splitvk's code. Passes when every
fovea pixel equals native in B, G and R (the X padding byte is ignored), when pixels outside the
foveae differ from native (the periphery was the client's reduced-rate one: the frame was split)
and when native has enough distinct colours that a blank window cannot pass.
"""
import argparse
import sys

MIN_COLOURS = 1000


def default_foveae(width, height, eyes):
    eye_w = width // eyes
    # lround of a positive value: half away from zero, not Python's round-half-to-even.
    fw = int(eye_w * 512.0 / 1200.0 + 0.5)
    fh = int(height * 360.0 / 1080.0 + 0.5)
    return [(e * eye_w + (eye_w - fw) // 2, (height - fh) // 2, fw, fh) for e in range(eyes)]


def rgb_pixels(row):
    """The B, G, R bytes of each pixel of a bgr0 row, padding dropped."""
    return [row[i:i + 3] for i in range(0, len(row), 4)]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", required=True)
    parser.add_argument("--eyes", type=int, choices=(1, 2), required=True)
    parser.add_argument("native")
    parser.add_argument("split")
    args = parser.parse_args()
    width, height = (int(v) for v in args.size.split("x"))
    frames = []
    for path in (args.native, args.split):
        with open(path, "rb") as f:
            data = f.read()
        if len(data) != width * height * 4:
            print(f"error: {path} holds {len(data)} bytes, not one {width}x{height} bgr0 frame", file=sys.stderr)
            return 1
        frames.append(data)
    native, split = frames
    stride = width * 4
    foveae = default_foveae(width, height, args.eyes)
    in_fovea = [[False] * width for _ in range(height)]
    ok = True
    for n, (x, y, w, h) in enumerate(foveae):
        differ, first = 0, None
        for row in range(y, y + h):
            a = rgb_pixels(native[row * stride + x * 4:row * stride + (x + w) * 4])
            b = rgb_pixels(split[row * stride + x * 4:row * stride + (x + w) * 4])
            for col in range(w):
                in_fovea[row][x + col] = True
                if a[col] != b[col]:
                    differ += 1
                    first = first or (x + col, row, a[col].hex(), b[col].hex())
        print(f"fovea {n} ({w}x{h} at {x},{y}): {w * h} pixels, {differ} differ from native")
        if differ:
            ok = False
            print(f"  first at {first[0]},{first[1]}: native bgr {first[2]}, split {first[3]}")
    outside = outside_differ = 0
    colours = set()
    for row in range(height):
        a = rgb_pixels(native[row * stride:(row + 1) * stride])
        b = rgb_pixels(split[row * stride:(row + 1) * stride])
        colours.update(a)
        for col in range(width):
            if not in_fovea[row][col]:
                outside += 1
                outside_differ += a[col] != b[col]
    print(f"outside the foveae: {outside_differ} of {outside} pixels differ from native")
    print(f"native frame: {len(colours)} distinct colours")
    if outside_differ == 0:
        ok = False
        print("error: the whole frame equals native: it was not split (the periphery is the client's)")
    if len(colours) < MIN_COLOURS:
        ok = False
        print(f"error: fewer than {MIN_COLOURS} colours: not the scene")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
