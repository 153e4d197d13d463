# XWD screenshot (xwd -root) to PNG with numpy + matplotlib, so a test leaves a picture a person can
# look at without ImageMagick. Handles the 24/32-bit TrueColor dumps Xvfb produces.
import struct, sys, numpy as np, matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
d = open(sys.argv[1], "rb").read()
h = struct.unpack(">25I", d[:100])
hsize, w, hgt, byte_order, bpp, bpl, ncolors = h[0], h[4], h[5], h[7], h[11], h[12], h[19]
off = hsize + ncolors * 12
px = np.frombuffer(d[off:off + bpl * hgt], dtype=np.uint8).reshape(hgt, bpl)[:, : w * 4].reshape(hgt, w, 4)
rgb = px[:, :, [2, 1, 0]] if byte_order == 0 else px[:, :, [1, 2, 3]]
plt.imsave(sys.argv[2], np.ascontiguousarray(rgb))
