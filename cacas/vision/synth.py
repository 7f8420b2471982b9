"""A procedural generator of SYNTHETIC home-scene images for the 6 scenes of Section III.

The paper fine-tunes ResNet on 200 real 640 x 360 photos per scene from its smart-home testbed
(Section V-A). None can be downloaded here, so this module draws simple rooms in one-point
perspective (back wall, side walls, floor, ceiling) with random colours, lighting, camera offset
and noise, and furniture typical of each scene: a bed with pillows (bedroom), a sofa, TV and rug
(living room), cabinets, a stove and a fridge (kitchen), tiles, a toilet, sink and tub (bathroom),
a table with chairs, plates and a pendant lamp (dining room), and corridors, stairs, a desk or a
garden (others).

These are NOT photographs: a model trained on them knows cartoon rooms, not real homes.
Researchers put their own photos in ``study_data/scenes/<scene>/`` and retrain.
"""

from __future__ import annotations

import numpy as np
from PIL import Image, ImageDraw, ImageFilter

from cacas import spaces

Rng = np.random.Generator


def _col(rng: Rng, base, spread=30):
    return tuple(int(np.clip(c + rng.uniform(-spread, spread), 0, 255)) for c in base)


def _pick(rng: Rng, options):
    return options[int(rng.integers(len(options)))]


class _Room:
    """A one-point-perspective room of size ``s``: back wall box (x0, y0, x1, y1)."""

    def __init__(self, rng: Rng, s: int, wall, floor, ceiling=(235, 235, 230)):
        self.s = s
        cx, cy = s * rng.uniform(0.4, 0.6), s * rng.uniform(0.38, 0.52)
        w, h = s * rng.uniform(0.45, 0.65), s * rng.uniform(0.35, 0.5)
        self.x0, self.x1 = cx - w / 2, cx + w / 2
        self.y0, self.y1 = cy - h / 2, cy + h / 2
        self.img = Image.new("RGB", (s, s), _col(rng, wall))
        d = ImageDraw.Draw(self.img)
        self.d = d
        side = tuple(int(c * 0.85) for c in _col(rng, wall, 10))
        d.polygon([(0, 0), (self.x0, self.y0), (self.x0, self.y1), (0, s)], fill=side)
        d.polygon([(s, 0), (self.x1, self.y0), (self.x1, self.y1), (s, s)], fill=side)
        d.polygon([(0, 0), (s, 0), (self.x1, self.y0), (self.x0, self.y0)], fill=_col(rng, ceiling, 15))
        d.polygon([(0, s), (s, s), (self.x1, self.y1), (self.x0, self.y1)], fill=_col(rng, floor))
        self.d.rectangle([self.x0, self.y0, self.x1, self.y1], outline=tuple(int(c * 0.7) for c in wall))

    def floor_y(self, depth: float) -> float:
        """Screen y of the floor at ``depth`` (0 = back wall, 1 = bottom of the image)."""
        return self.y1 + depth * (self.s - self.y1)

    def scale(self, depth: float) -> float:
        return 1 + depth * (self.s / max(1.0, self.y1 - self.y0) - 1) * 0.5

    def window(self, rng: Rng):
        x = rng.uniform(self.x0 + 5, self.x1 - 30)
        y = rng.uniform(self.y0 + 4, self.y0 + 12)
        w, h = rng.uniform(18, 30), rng.uniform(16, 26)
        self.d.rectangle([x, y, x + w, y + h], fill=_col(rng, (170, 205, 240), 20), outline=(250, 250, 250), width=2)
        self.d.line([x + w / 2, y, x + w / 2, y + h], fill=(250, 250, 250), width=1)
        if rng.random() < 0.7:
            c = _col(rng, _pick(rng, [(160, 60, 60), (60, 90, 150), (200, 180, 120)]), 30)
            self.d.rectangle([x - 4, y - 2, x + 3, y + h + 6], fill=c)
            self.d.rectangle([x + w - 3, y - 2, x + w + 4, y + h + 6], fill=c)


def _rug(room, rng, depth=0.4):
    y = room.floor_y(depth)
    c = _col(rng, _pick(rng, [(150, 50, 50), (60, 80, 140), (180, 160, 110), (90, 120, 80)]), 30)
    room.d.polygon([(room.s * 0.25, y), (room.s * 0.75, y), (room.s * 0.85, y + 25), (room.s * 0.15, y + 25)], fill=c)


def _bedroom(rng: Rng, s: int) -> Image.Image:
    room = _Room(rng, s, _pick(rng, [(220, 200, 180), (200, 210, 230), (230, 220, 200), (210, 190, 210)]),
                 _pick(rng, [(150, 110, 70), (170, 130, 90), (120, 120, 130)]))
    d = room.d
    if rng.random() < 0.7:
        room.window(rng)
    bx0 = s * rng.uniform(0.1, 0.35)
    bw = s * rng.uniform(0.45, 0.6)
    top = room.floor_y(0.05) - s * 0.12
    bot = room.floor_y(rng.uniform(0.55, 0.8))
    d.rectangle([bx0, top - 10, bx0 + bw, top + 12], fill=_col(rng, (110, 70, 40)))  # headboard
    blanket = _col(rng, _pick(rng, [(70, 100, 170), (190, 80, 90), (220, 210, 180), (90, 140, 110)]), 40)
    d.polygon([(bx0, top + 8), (bx0 + bw, top + 8), (bx0 + bw * 1.1, bot), (bx0 - bw * 0.1, bot)], fill=blanket)
    for k in range(2):  # pillows
        px = bx0 + 6 + k * bw / 2
        d.rounded_rectangle([px, top + 2, px + bw / 2 - 12, top + 16], radius=4, fill=(245, 245, 240))
    d.rectangle([bx0 - bw * 0.1, bot, bx0 + bw * 1.1, bot + 8], fill=_col(rng, (90, 60, 40)))
    if rng.random() < 0.8:  # nightstand and lamp
        nx = bx0 + bw + 6 if bx0 + bw + 30 < s else bx0 - 28
        d.rectangle([nx, top + 10, nx + 20, top + 34], fill=_col(rng, (120, 80, 50)))
        d.polygon([(nx + 4, top - 4), (nx + 16, top - 4), (nx + 19, top + 8), (nx + 1, top + 8)], fill=(250, 230, 170))
    return room.img


def _living_room(rng: Rng, s: int) -> Image.Image:
    room = _Room(rng, s, _pick(rng, [(230, 230, 220), (200, 215, 200), (235, 225, 205), (190, 200, 215)]),
                 _pick(rng, [(160, 120, 80), (190, 170, 140), (140, 140, 140)]))
    d = room.d
    tv_w = (room.x1 - room.x0) * rng.uniform(0.35, 0.5)
    tx = rng.uniform(room.x0 + 4, room.x1 - tv_w - 4)
    ty = room.y0 + (room.y1 - room.y0) * rng.uniform(0.2, 0.35)
    d.rectangle([tx, ty, tx + tv_w, ty + tv_w * 0.58], fill=(15, 15, 20), outline=(60, 60, 60), width=2)
    if rng.random() < 0.5:  # a picture on screen
        d.rectangle([tx + 3, ty + 3, tx + tv_w - 3, ty + tv_w * 0.58 - 3], fill=_col(rng, (60, 110, 160), 60))
    d.rectangle([tx - 6, room.y1 - 10, tx + tv_w + 6, room.y1], fill=_col(rng, (90, 60, 40)))
    _rug(room, rng, rng.uniform(0.2, 0.4))
    sc = _col(rng, _pick(rng, [(120, 120, 130), (150, 90, 60), (70, 90, 120), (180, 170, 150)]), 30)
    sy = room.floor_y(rng.uniform(0.55, 0.75))
    sx0, sx1 = s * rng.uniform(0.05, 0.2), s * rng.uniform(0.8, 0.95)
    d.rounded_rectangle([sx0, sy - 30, sx1, sy - 8], radius=6, fill=sc)  # back
    d.rounded_rectangle([sx0, sy - 14, sx1, sy + 6], radius=5, fill=tuple(int(c * 0.85) for c in sc))  # seat
    d.rounded_rectangle([sx0 - 6, sy - 22, sx0 + 8, sy + 8], radius=4, fill=sc)
    d.rounded_rectangle([sx1 - 8, sy - 22, sx1 + 6, sy + 8], radius=4, fill=sc)
    if rng.random() < 0.6:  # plant
        px = _pick(rng, [room.x0 - 5, room.x1 - 10])
        d.rectangle([px, room.y1 - 12, px + 12, room.y1 + 4], fill=(150, 80, 50))
        d.ellipse([px - 8, room.y1 - 38, px + 20, room.y1 - 8], fill=_col(rng, (50, 130, 60), 25))
    return room.img


def _kitchen(rng: Rng, s: int) -> Image.Image:
    room = _Room(rng, s, _pick(rng, [(235, 235, 230), (220, 230, 235), (240, 230, 210)]),
                 _pick(rng, [(200, 200, 195), (120, 120, 125), (180, 150, 120)]))
    d = room.d
    cab = _col(rng, _pick(rng, [(245, 245, 240), (110, 80, 55), (60, 90, 110), (170, 190, 170)]), 20)
    top = room.y1 - (room.y1 - room.y0) * 0.35
    d.rectangle([room.x0, top, room.x1, room.y1], fill=cab)  # base cabinets
    d.rectangle([room.x0, top - 4, room.x1, top], fill=_col(rng, (90, 90, 95), 40))  # counter top
    n = int(rng.integers(3, 6))
    w = (room.x1 - room.x0) / n
    for k in range(n):
        x = room.x0 + k * w
        d.rectangle([x + 1, top + 2, x + w - 1, room.y1 - 1], outline=tuple(int(c * 0.7) for c in cab))
        d.line([x + w / 2 - 3, top + 6, x + w / 2 + 3, top + 6], fill=(60, 60, 60), width=1)
        d.rectangle([x + 1, room.y0 + 2, x + w - 1, room.y0 + (room.y1 - room.y0) * 0.3], fill=cab,
                    outline=tuple(int(c * 0.7) for c in cab))
    tile = _col(rng, (230, 230, 225), 20)  # backsplash grid
    for yy in np.arange(room.y0 + (room.y1 - room.y0) * 0.32, top - 4, 4):
        d.line([room.x0, yy, room.x1, yy], fill=tuple(int(c * 0.85) for c in tile))
    sx = rng.uniform(room.x0 + 2, room.x1 - 30)  # stove
    d.rectangle([sx, top - 7, sx + 28, top - 3], fill=(30, 30, 30))
    for k in range(2):
        d.ellipse([sx + 3 + k * 13, top - 7, sx + 12 + k * 13, top - 4], outline=(200, 60, 30) if rng.random() < 0.5 else (90, 90, 90))
    fx = _pick(rng, [room.x0 - 28, room.x1 + 2])  # fridge
    d.rectangle([fx, room.y0 - 8, fx + 26, room.y1 + 10], fill=_col(rng, (225, 225, 225), 15), outline=(150, 150, 150))
    d.line([fx, room.y0 + 25, fx + 26, room.y0 + 25], fill=(150, 150, 150))
    return room.img


def _bathroom(rng: Rng, s: int) -> Image.Image:
    wall = _pick(rng, [(235, 240, 245), (200, 225, 235), (230, 230, 230), (215, 235, 220)])
    room = _Room(rng, s, wall, _pick(rng, [(200, 200, 205), (150, 170, 180), (230, 230, 225)]))
    d = room.d
    step = rng.uniform(5, 9)
    line = tuple(int(c * 0.82) for c in wall)
    for x in np.arange(0, s, step):  # tiles everywhere on the walls
        d.line([x, 0, x, room.y1 if room.x0 < x < room.x1 else s], fill=line)
    for y in np.arange(0, room.y1, step):
        d.line([0, y, s, y], fill=line)
    white = (248, 248, 250)
    if rng.random() < 0.8:  # tub
        ty = room.floor_y(0.15)
        d.rounded_rectangle([s * 0.05, ty - 18, s * rng.uniform(0.45, 0.6), ty + 6], radius=8, fill=white,
                            outline=(190, 190, 200))
    tx = s * rng.uniform(0.55, 0.75)  # toilet
    ty = room.floor_y(rng.uniform(0.35, 0.6))
    d.rectangle([tx, ty - 34, tx + 22, ty - 18], fill=white, outline=(190, 190, 200))
    d.ellipse([tx - 4, ty - 20, tx + 26, ty - 6], fill=white, outline=(190, 190, 200))
    d.rectangle([tx + 5, ty - 10, tx + 17, ty + 4], fill=white)
    mx = rng.uniform(room.x0 + 4, room.x1 - 26)  # mirror and sink
    d.rectangle([mx, room.y0 + 4, mx + 22, room.y0 + 24], fill=(200, 220, 235), outline=(160, 160, 170), width=2)
    d.ellipse([mx - 2, room.y1 - 22, mx + 24, room.y1 - 14], fill=white, outline=(180, 180, 190))
    if rng.random() < 0.6:  # towel
        d.rectangle([room.x1 - 12, room.y0 + 10, room.x1 - 4, room.y0 + 30], fill=_col(rng, (200, 80, 80), 60))
    return room.img


def _dining_room(rng: Rng, s: int) -> Image.Image:
    room = _Room(rng, s, _pick(rng, [(235, 225, 205), (215, 200, 180), (225, 230, 235), (240, 235, 225)]),
                 _pick(rng, [(140, 100, 60), (170, 140, 100), (110, 90, 70)]))
    d = room.d
    if rng.random() < 0.6:
        room.window(rng)
    cx = s * rng.uniform(0.4, 0.6)
    ty = room.floor_y(rng.uniform(0.2, 0.35))
    tw = s * rng.uniform(0.25, 0.35)
    wood = _col(rng, (130, 85, 50), 35)
    chair = _col(rng, _pick(rng, [(100, 65, 40), (40, 40, 40), (180, 160, 130)]), 20)
    for k in (-1, 1):  # chairs behind the table
        x = cx + k * tw * 0.5
        d.rectangle([x - 7, ty - 34, x + 7, ty - 6], fill=chair)
    top = [(cx - tw * 0.8, ty), (cx + tw * 0.8, ty), (cx + tw, ty + 18), (cx - tw, ty + 18)]
    cloth = rng.random() < 0.4
    d.polygon(top, fill=(245, 245, 245) if cloth else wood)
    for k in (-1, 1):
        d.rectangle([cx + k * tw * 0.9 - 2, ty + 18, cx + k * tw * 0.9 + 2, ty + 45], fill=wood)
    for k in range(int(rng.integers(2, 5))):  # plates
        px = cx - tw * 0.6 + k * tw * 0.4
        d.ellipse([px - 6, ty + 6, px + 6, ty + 12], fill=(250, 250, 250), outline=(180, 180, 180))
    for k in (-1, 1):  # chairs in front, at the sides
        x = cx + k * (tw + 10)
        d.rectangle([x - 6, ty + 5, x + 6, ty + 40], fill=chair)
    d.line([cx, 0, cx, room.y0 - 2], fill=(40, 40, 40))  # pendant lamp
    d.pieslice([cx - 14, room.y0 - 12, cx + 14, room.y0 + 12], 180, 360, fill=_col(rng, (240, 210, 120), 30))
    return room.img


def _others(rng: Rng, s: int) -> Image.Image:
    kind = int(rng.integers(4))
    if kind == 3:  # a garden / balcony
        img = Image.new("RGB", (s, s), _col(rng, (140, 190, 235), 20))
        d = ImageDraw.Draw(img)
        hz = s * rng.uniform(0.4, 0.6)
        d.rectangle([0, hz, s, s], fill=_col(rng, (80, 150, 70), 25))
        for _ in range(int(rng.integers(2, 5))):
            x = rng.uniform(0, s)
            d.rectangle([x - 2, hz - 20, x + 2, hz + 5], fill=(100, 70, 40))
            d.ellipse([x - 14, hz - 45, x + 14, hz - 15], fill=_col(rng, (40, 110, 50), 20))
        d.rectangle([0, s * 0.85, s, s * 0.88], fill=(120, 120, 120))
        return img
    room = _Room(rng, s, _pick(rng, [(220, 220, 215), (200, 200, 200), (230, 225, 210)]),
                 _pick(rng, [(130, 130, 130), (160, 140, 120), (100, 100, 110)]))
    d = room.d
    if kind == 0:  # corridor with doors on the side walls
        for k in range(int(rng.integers(2, 4))):
            f = 0.15 + 0.25 * k
            x = f * room.x0
            d.rectangle([x, s * 0.2 + f * 20, x + 10, s * 0.75 - f * 10], fill=_col(rng, (140, 100, 60), 30))
        d.rectangle([room.x0 + (room.x1 - room.x0) * 0.35, room.y0 + 6, room.x0 + (room.x1 - room.x0) * 0.65, room.y1],
                    fill=_col(rng, (150, 110, 70), 30))
    elif kind == 1:  # stairs
        n = int(rng.integers(6, 10))
        for k in range(n):
            y = room.y1 + (s - room.y1) * k / n
            d.rectangle([s * 0.2, y, s * 0.8, y + (s - room.y1) / n], fill=_col(rng, (150, 120, 90), 15),
                        outline=(80, 60, 40))
        d.line([s * 0.15, room.y1 - 15, s * 0.15, s], fill=(60, 60, 60), width=3)
    else:  # a home office: desk and monitor
        dy = room.floor_y(0.25)
        d.rectangle([s * 0.2, dy - 4, s * 0.8, dy + 2], fill=_col(rng, (200, 200, 200), 40))
        d.rectangle([s * 0.22, dy + 2, s * 0.25, dy + 35], fill=(60, 60, 60))
        d.rectangle([s * 0.75, dy + 2, s * 0.78, dy + 35], fill=(60, 60, 60))
        d.rectangle([s * 0.4, dy - 30, s * 0.6, dy - 10], fill=(20, 20, 25))
        d.rectangle([s * 0.48, dy - 10, s * 0.52, dy - 4], fill=(60, 60, 60))
        for k in range(int(rng.integers(2, 5))):  # shelves of boxes
            d.rectangle([room.x0 + 4 + k * 12, room.y0 + 8, room.x0 + 14 + k * 12, room.y0 + 22],
                        fill=_col(rng, (150, 130, 100), 60))
    return room.img


GENERATORS = {"bedroom": _bedroom, "living room": _living_room, "kitchen": _kitchen, "bathroom": _bathroom,
              "dining room": _dining_room, "others": _others}
assert tuple(GENERATORS) == spaces.SCENES


def render(scene: str, rng: Rng, size: int = 128) -> Image.Image:
    """One synthetic ``size`` x ``size`` RGB image of ``scene`` (a Table I scene name)."""
    name = spaces.canonical("scene", scene)
    big = max(2 * size, 96)  # draw at twice the size (at least 96: the furniture needs room), then shrink
    img = GENERATORS[name](rng, big)
    # lighting: a brightness gradient and a colour cast, then sensor noise and slight blur
    arr = np.asarray(img, dtype=np.float32)
    gx = np.linspace(rng.uniform(0.75, 1.1), rng.uniform(0.75, 1.1), big)[None, :, None]
    gy = np.linspace(rng.uniform(0.85, 1.1), rng.uniform(0.7, 1.0), big)[:, None, None]
    cast = rng.uniform(0.9, 1.1, 3)[None, None, :]
    arr = arr * gx * gy * cast + rng.normal(0, rng.uniform(2, 8), arr.shape)
    img = Image.fromarray(np.clip(arr, 0, 255).astype(np.uint8))
    img = img.filter(ImageFilter.GaussianBlur(rng.uniform(0.3, 1.2)))
    return img.resize((size, size), Image.BILINEAR)
