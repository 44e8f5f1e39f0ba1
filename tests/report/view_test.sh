#!/usr/bin/env bash
# CTest report.view_renders_in_a_browser: report.html of a short run opened in headless Chromium
# (WebGL through SwiftShader). Checks that the 3D view started and drew as many vertices as the
# report embeds, that its canvas shows the mesh (pixels other than the background), and that the
# layers 'after recovery' and 'sensed only' give different pictures.
# Usage: view_test.sh TERRAIN WORK_DIR
set -euo pipefail
terrain=$1 work=$2
browser=$(command -v chromium || command -v chromium-browser || true)
[ -n "$browser" ] || { echo "FAIL: no chromium (scripts/install-deps installs it)"; exit 1; }
rm -rf "$work"
mkdir -p "$work"
"$terrain" run --scenario urban --seed 1 --frames 12 --out "$work/run" > "$work/run.log" 2>&1 ||
  { cat "$work/run.log"; echo "FAIL: the run failed"; exit 1; }
page="file://$work/run/report.html"
open_page() {  # open_page HASH OUT_PNG: a screenshot of the page's top after it has loaded
  timeout 120 "$browser" --headless --no-sandbox --disable-gpu-sandbox --enable-unsafe-swiftshader \
    --use-angle=swiftshader --user-data-dir="$work/profile" --window-size=1280,1000 --hide-scrollbars \
    --virtual-time-budget=20000 --screenshot="$2" "$page#$1" > /dev/null 2>&1
}
timeout 120 "$browser" --headless --no-sandbox --disable-gpu-sandbox --enable-unsafe-swiftshader --use-angle=swiftshader \
  --user-data-dir="$work/profile" --virtual-time-budget=20000 --dump-dom "$page#layer=after" 2> /dev/null > "$work/dom.html"
open_page "layer=after" "$work/after.png"
open_page "layer=before" "$work/before.png"
python3 - "$work/run/report.html" "$work/dom.html" "$work/after.png" "$work/before.png" <<'PY'
import re, struct, sys, zlib

def png(path):
    """8-bit RGB or RGBA, non-interlaced PNG -> (width, height, rows of RGB tuples)"""
    data = open(path, "rb").read()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", f"{path}: not a PNG"
    pos, idat = 8, b""
    while pos < len(data):
        n, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        if kind == b"IHDR":
            w, h, depth, colour, _, _, interlace = struct.unpack(">IIBBBBB", body)
            assert depth == 8 and colour in (2, 6) and interlace == 0, f"{path}: unsupported PNG"
        elif kind == b"IDAT":
            idat += body
        pos += 12 + n
    bpp = 3 if colour == 2 else 4
    raw, stride, prev, rows = zlib.decompress(idat), w * bpp, bytearray(w * bpp), []
    for y in range(h):
        f, line = raw[y * (stride + 1)], bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - bpp] if i >= bpp else 0
            b, c = prev[i], prev[i - bpp] if i >= bpp else 0
            if f == 1: line[i] = (line[i] + a) & 255
            elif f == 2: line[i] = (line[i] + b) & 255
            elif f == 3: line[i] = (line[i] + (a + b) // 2) & 255
            elif f == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[i] = (line[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        rows.append([tuple(line[x * bpp:x * bpp + 3]) for x in range(w)])
        prev = line
    return w, h, rows

report, dom, after_png, before_png = sys.argv[1:5]
embedded = int(re.search(r'<span id="terrain-view-count">(\d+)</span>', open(report).read()).group(1))
page = open(dom).read()
holder = re.search(r'<div id="terrain-view"[^>]*>', page)
assert holder, "FAIL: no view holder in the page"
tag = holder.group(0)
assert 'data-ready="1"' in tag, f"FAIL: the view did not start: {re.search(r'id=.terrain-view-status.[^<]*', page).group(0)}"
drawn = int(re.search(r'data-vertices="(\d+)"', tag).group(1))
assert drawn == embedded and embedded > 0, f"FAIL: the page drew {drawn} vertices, the report embeds {embedded}"
print(f"the page drew {drawn} vertices, as many as the report embeds")

background = (0xf2, 0xf4, 0xf7)
w, h, after = png(after_png)
_, _, before = png(before_png)
# the canvas: the bounding box of the view's background colour
box = [(x, y) for y in range(h) for x in range(w) if after[y][x] == background]
assert box, "FAIL: no canvas (background colour) in the screenshot"
x0, x1 = min(p[0] for p in box), max(p[0] for p in box)
y0, y1 = min(p[1] for p in box), max(p[1] for p in box)
area = (x1 - x0 + 1) * (y1 - y0 + 1)
drawn_px = sum(after[y][x] != background for y in range(y0, y1 + 1) for x in range(x0, x1 + 1))
changed = sum(after[y][x] != before[y][x] for y in range(y0, y1 + 1) for x in range(x0, x1 + 1))
print(f"canvas {x1 - x0 + 1} x {y1 - y0 + 1} px: {drawn_px} px not background ({100 * drawn_px / area:.1f} %), "
      f"{changed} px differ between after recovery and sensed only ({100 * changed / area:.2f} %)")
assert x1 - x0 > 400 and y1 - y0 > 300, "FAIL: the canvas is too small"
assert drawn_px > 0.02 * area, "FAIL: the canvas shows (almost) nothing but background"
assert changed > 0.001 * area, "FAIL: the before/after toggle does not change the picture"
print("PASS")
PY
