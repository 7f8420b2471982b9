"""A procedural generator of SYNTHETIC household sounds for the 33 activities of Section III.

The paper trains on 200 real 1-s recordings per activity (Google AudioSet, CHIME-home, FreeSound,
self-recorded; Section V-A). No such recordings can be downloaded here, so this module
synthesises a plausible, varied texture for each activity from noise, tones, pulse trains and
filters: running water for washing, motor hum for the blender, fan and microwave, short bursts for
cough and sneeze, clicks for typing, crackle for frying, a rush for the toilet flush, room tone for
"do nothing", and so on. Every clip gets random variation (pitch, rate, timing, colour), room
reverberation (a random exponentially decaying impulse response) and background noise.

These clips are NOT real recordings: a model trained on them learns the synthetic textures, and
its accuracy says nothing about real homes. Researchers import their own recordings with
:func:`cacas.audio.library.import_folder`; everything else works the same on them.

Event sounds (cough, sneeze, fall ...) are repeated or followed by their aftermath so that every
1-s window of a clip holds part of the activity (a window of pure background labelled "cough"
would teach the model nothing but confusion with "do nothing").
"""

from __future__ import annotations

from typing import Callable

import numpy as np
from scipy import signal as sps

from cacas import spaces
from cacas.audio.features import SAMPLE_RATE

SR = SAMPLE_RATE
Rng = np.random.Generator


# ----------------------------------------------------------------------------- building blocks
def _t(n: int) -> np.ndarray:
    return np.arange(n) / SR


def _noise(rng: Rng, n: int) -> np.ndarray:
    return rng.standard_normal(n).astype(np.float64)


def _band(x: np.ndarray, lo: float | None, hi: float | None, order: int = 2) -> np.ndarray:
    """Butterworth band-, low- or high-pass (None leaves that side open)."""
    nyq = SR / 2
    if lo and hi:
        sos = sps.butter(order, [lo / nyq, min(hi, nyq * 0.98) / nyq], btype="band", output="sos")
    elif lo:
        sos = sps.butter(order, lo / nyq, btype="high", output="sos")
    elif hi:
        sos = sps.butter(order, min(hi, nyq * 0.98) / nyq, btype="low", output="sos")
    else:
        return x
    return sps.sosfilt(sos, x)


def _pink(rng: Rng, n: int) -> np.ndarray:
    spec = np.fft.rfft(_noise(rng, n))
    f = np.fft.rfftfreq(n, 1 / SR)
    spec[1:] /= np.sqrt(f[1:])
    spec[0] = 0
    y = np.fft.irfft(spec, n)
    return y / (np.std(y) + 1e-12)


def _norm(x: np.ndarray) -> np.ndarray:
    return x / (np.max(np.abs(x)) + 1e-12)


def _env(n: int, attack: float, decay: float) -> np.ndarray:
    """Linear attack then exponential decay (time constants in seconds)."""
    t = _t(n)
    a = np.clip(t / max(attack, 1e-4), 0, 1)
    return a * np.exp(-np.maximum(t - attack, 0) / max(decay, 1e-4))


def _smooth_random(rng: Rng, n: int, rate_hz: float, depth: float) -> np.ndarray:
    """A slowly varying random curve around 1 (control points at ``rate_hz``)."""
    k = max(2, int(n / SR * rate_hz) + 2)
    pts = 1 + depth * rng.uniform(-1, 1, k)
    return np.interp(np.linspace(0, k - 1, n), np.arange(k), pts)


def _voiced(rng: Rng, f0: np.ndarray, formants, breath: float = 0.1, jitter: float = 0.01) -> np.ndarray:
    """A glottal-pulse-like source at pitch contour ``f0`` through formant band-passes."""
    n = len(f0)
    f = f0 * (1 + jitter * _band(_noise(rng, n), None, 30))
    phase = np.cumsum(f) / SR
    src = 2 * (phase % 1.0) - 1  # sawtooth: rich harmonics
    src = src + breath * _noise(rng, n)
    out = np.zeros(n)
    for centre, width, gain in formants:
        out += gain * _band(src, max(40, centre - width / 2), centre + width / 2)
    return out


def _ring(rng: Rng, n: int, freqs, decay: float, inharm: float = 0.0) -> np.ndarray:
    """Sum of exponentially decaying sinusoids: impacts, clinks, knocks."""
    t = _t(n)
    out = np.zeros(n)
    for i, f in enumerate(freqs):
        f = f * (1 + inharm * rng.uniform(-1, 1))
        out += np.exp(-t / (decay / (1 + 0.3 * i))) * np.sin(2 * np.pi * f * t + rng.uniform(0, 6.3)) / (1 + i)
    return out


def _place(n: int, rng: Rng, make: Callable[[], np.ndarray], gap: tuple[float, float],
           first: tuple[float, float] = (0.0, 0.25), gain: tuple[float, float] = (0.6, 1.0)) -> np.ndarray:
    """Events from ``make()`` at random starts, ``gap`` seconds apart, filling the clip."""
    out = np.zeros(n)
    pos = int(rng.uniform(*first) * SR)
    while pos < n:
        ev = make() * rng.uniform(*gain)
        m = min(len(ev), n - pos)
        out[pos:pos + m] += ev[:m]
        pos += int(rng.uniform(*gap) * SR)
    return out


def _motor(rng: Rng, n: int, f0: float, n_harm: int, wobble: float = 0.01, roll: float = 0.8) -> np.ndarray:
    """A motor / mains hum: a fundamental with decaying harmonics and slight speed wobble."""
    f = f0 * _smooth_random(rng, n, 3, wobble)
    phase = 2 * np.pi * np.cumsum(f) / SR
    out = np.zeros(n)
    for h in range(1, n_harm + 1):
        out += (roll ** (h - 1)) * rng.uniform(0.5, 1.0) * np.sin(h * phase + rng.uniform(0, 6.3))
    return out


def _water(rng: Rng, n: int, lo: float = 400, hi: float = 6000, bubbles: float = 60) -> np.ndarray:
    """Running water: fluctuating band noise plus random bubble chirps."""
    base = _band(_noise(rng, n), lo, hi) * _smooth_random(rng, n, 25, 0.5)
    t = np.arange(int(0.02 * SR)) / SR
    out = base / (np.std(base) + 1e-12)
    for _ in range(int(bubbles * n / SR)):
        f = rng.uniform(600, 3500)
        chirp = np.sin(2 * np.pi * (f * t + f * 8 * t ** 2)) * np.exp(-t / rng.uniform(0.003, 0.01))
        p = rng.integers(0, max(1, n - len(t)))
        out[p:p + len(t)] += rng.uniform(0.5, 2.0) * chirp
    return out


# ----------------------------------------------------------------------------- body sounds
def _cough(rng, n):
    def one():
        m = int(rng.uniform(0.18, 0.32) * SR)
        burst = _band(_noise(rng, m), rng.uniform(250, 500), rng.uniform(2500, 4500))
        f0 = np.full(m, rng.uniform(120, 260))
        voice = _voiced(rng, f0, [(rng.uniform(500, 800), 300, 1.0), (1500, 500, 0.5)], 0.3)
        return _norm(burst + 0.6 * _norm(voice)) * _env(m, 0.008, rng.uniform(0.05, 0.09))
    return _place(n, rng, one, (0.3, 0.7))


def _cry(rng, n):
    t = _t(n)
    base = rng.uniform(330, 520)
    contour = base * (1 + 0.25 * np.sin(2 * np.pi * rng.uniform(0.4, 0.9) * t + rng.uniform(0, 6.3)))
    contour *= 1 + 0.03 * np.sin(2 * np.pi * rng.uniform(5, 8) * t)  # vibrato
    v = _voiced(rng, contour, [(rng.uniform(900, 1200), 400, 1.0), (rng.uniform(2200, 2800), 600, 0.6),
                               (3500, 800, 0.3)], breath=0.2)
    sob = np.clip(np.sin(2 * np.pi * rng.uniform(1.2, 2.2) * t + rng.uniform(0, 6.3)), 0, 1) ** 0.5
    return v * (0.3 + 0.7 * sob)


def _clear_throat(rng, n):
    def one():
        m = int(rng.uniform(0.35, 0.55) * SR)
        f0 = np.linspace(rng.uniform(110, 160), rng.uniform(80, 110), m)
        rough = 1 + 0.6 * np.sign(np.sin(2 * np.pi * rng.uniform(25, 40) * _t(m)))
        v = _voiced(rng, f0, [(rng.uniform(400, 600), 300, 1.0), (1100, 400, 0.4)], breath=0.6, jitter=0.05)
        env = _env(m, 0.03, 0.15) + 0.8 * np.roll(_env(m, 0.02, 0.08), int(0.15 * m))
        return v * rough * env
    return _place(n, rng, one, (0.45, 0.75))


def _sneeze(rng, n):
    def one():
        inh = int(rng.uniform(0.25, 0.4) * SR)
        burst = int(rng.uniform(0.15, 0.25) * SR)
        a = _band(_noise(rng, inh), 800, 3000) * np.linspace(0, 0.3, inh) ** 2
        f0 = np.full(inh, rng.uniform(200, 300))
        a += 0.15 * _voiced(rng, f0, [(700, 300, 1)], 0.5) * np.linspace(0, 1, inh)
        b = _band(_noise(rng, burst), rng.uniform(1500, 2500), 12000) * _env(burst, 0.003, rng.uniform(0.04, 0.07))
        return np.concatenate([a * 0.4, _norm(b)])
    return _place(n, rng, one, (0.5, 0.8), first=(0.0, 0.1))


def _sniff(rng, n):
    def one():
        m = int(rng.uniform(0.08, 0.16) * SR)
        return _band(_noise(rng, m), rng.uniform(1500, 2500), rng.uniform(6000, 9000)) * np.sin(np.linspace(0, np.pi, m)) ** 2
    return 0.6 * _place(n, rng, one, (0.15, 0.45))


def _fall_down(rng, n):
    out = np.zeros(n)
    pos = int(rng.uniform(0.0, 0.3) * SR)
    k = 0
    while pos < n:  # the fall, then bounces / objects rolling and settling
        m = int(0.5 * SR)
        thud = _ring(rng, m, [rng.uniform(50, 90), rng.uniform(110, 180)], rng.uniform(0.05, 0.12))
        thud += 0.5 * _band(_noise(rng, m), 60, 800) * _env(m, 0.002, 0.04)
        g = 1.0 if k == 0 else rng.uniform(0.25, 0.6)
        if k > 0 and rng.random() < 0.6:  # rattling object
            thud += 0.3 * _ring(rng, m, [rng.uniform(1200, 2500), rng.uniform(3000, 5000)], 0.08, 0.05)
        mm = min(m, n - pos)
        out[pos:pos + mm] += g * _norm(thud)[:mm]
        pos += int(rng.uniform(0.2, 0.6) * SR)
        k += 1
    return out


def _burp(rng, n):
    def one():
        m = int(rng.uniform(0.3, 0.55) * SR)
        f0 = rng.uniform(55, 95) * _smooth_random(rng, m, 12, 0.25)
        v = _voiced(rng, f0, [(rng.uniform(300, 450), 250, 1.0), (900, 300, 0.4)], breath=0.2, jitter=0.15)
        return v * np.sin(np.linspace(0, np.pi, m)) ** 0.7
    return _place(n, rng, one, (0.5, 0.75))


def _yawn(rng, n):
    f0 = np.linspace(rng.uniform(220, 300), rng.uniform(110, 150), n)
    f1 = np.linspace(rng.uniform(700, 900), rng.uniform(400, 550), n)
    v = _voiced(rng, f0, [(np.mean(f1), 350, 1.0), (rng.uniform(1100, 1300), 400, 0.5)], breath=0.8)
    breath = _band(_noise(rng, n), 300, 2500) * 0.3
    env = np.sin(np.linspace(0, np.pi, n)) ** 0.6 * _smooth_random(rng, n, 2, 0.2)
    return (v + breath * np.std(v) * 3) * env


def _snore(rng, n):
    t = _t(n)
    period = rng.uniform(1.2, 2.0)
    breath = np.clip(np.sin(2 * np.pi * t / period + rng.uniform(0, 6.3)), 0, 1)
    flutter = rng.uniform(25, 55)
    src = np.maximum(np.sin(2 * np.pi * flutter * t), 0) ** 3 + 0.3 * _noise(rng, n) * 0.3
    s = _band(src, 40, rng.uniform(600, 1000))
    s += 0.3 * _band(_noise(rng, n), 300, 1500) * breath
    return s * (0.08 + breath)


# ----------------------------------------------------------------------------- eating and drinking
def _gulp(rng, f_lo, f_hi, dur):
    m = int(dur * SR)
    f = np.linspace(rng.uniform(f_lo, f_hi), rng.uniform(f_lo, f_hi) * 0.6, m)
    tone = np.sin(2 * np.pi * np.cumsum(f) / SR) * _env(m, 0.005, dur / 3)
    click = _band(_noise(rng, m), 200, 2000) * _env(m, 0.001, 0.01)
    return tone + 0.5 * click


def _drink_water(rng, n):
    out = _place(n, rng, lambda: _gulp(rng, 400, 700, rng.uniform(0.1, 0.15)), (0.3, 0.45))
    glass = 0.15 * _band(_noise(rng, n), 2000, 6000) * _smooth_random(rng, n, 30, 0.9)
    return out + glass


def _drink_milk(rng, n):
    def one():
        g = _gulp(rng, 180, 320, rng.uniform(0.2, 0.3))
        throat = 0.4 * _band(_noise(rng, len(g)), 100, 600) * _env(len(g), 0.05, 0.1)
        return g + throat
    return _place(n, rng, one, (0.5, 0.7))


def _drink_soup(rng, n):
    def slurp():
        m = int(rng.uniform(0.25, 0.4) * SR)
        x = _noise(rng, m)
        lo = np.linspace(rng.uniform(600, 900), rng.uniform(2000, 3500), m)
        seg = np.zeros(m)
        step = 800
        for i in range(0, m, step):  # a band sweeping upward
            seg[i:i + step] = _band(x[i:i + step], lo[i], lo[i] * 2)[:len(seg[i:i + step])]
        return seg * np.sin(np.linspace(0, np.pi, m)) * _smooth_random(rng, m, 60, 0.8)

    def spoon():
        m = int(0.25 * SR)
        return 0.5 * _ring(rng, m, [rng.uniform(2500, 4000), rng.uniform(5000, 7000)], 0.06, 0.05)

    return _place(n, rng, lambda: np.concatenate([spoon(), slurp()]) if rng.random() < 0.5 else slurp(), (0.4, 0.7))


def _crunches(rng, m, rate, lo, hi, dec):
    out = np.zeros(m)
    k = int(rate * m / SR)
    for p in rng.integers(0, m - 200, k):
        L = 200
        out[p:p + L] += rng.uniform(0.2, 1.0) * _noise(rng, L) * np.exp(-np.arange(L) / (dec * SR))
    return _band(out, lo, hi)


def _eat_apple(rng, n):
    def chew():
        m = int(rng.uniform(0.18, 0.3) * SR)
        c = _crunches(rng, m, rng.uniform(150, 300), 500, 5000, 0.002) * np.sin(np.linspace(0, np.pi, m))
        juice = 0.2 * _band(_noise(rng, m), 1000, 4000) * _env(m, 0.02, 0.1)
        return c + juice
    bite = _crunches(rng, int(0.25 * SR), 600, 400, 7000, 0.003) * _env(int(0.25 * SR), 0.005, 0.08) * 2
    out = _place(n, rng, chew, (0.3, 0.5))
    p = int(rng.uniform(0, 0.5) * SR)
    out[p:p + len(bite)] += bite[:n - p]
    return out


def _eat_noodle(rng, n):
    t = _t(n)
    slurp = _band(_noise(rng, n), 400, 2500) * (0.5 + 0.5 * np.sin(2 * np.pi * rng.uniform(6, 12) * t) ** 2)
    gate = np.clip(np.sin(2 * np.pi * rng.uniform(0.6, 1.0) * t + rng.uniform(0, 6.3)) + 0.3, 0, 1)
    chew = _place(n, rng, lambda: _band(_noise(rng, 3000), 100, 800) * _env(3000, 0.01, 0.03), (0.25, 0.4))
    return slurp * gate + 0.5 * _norm(chew) * np.std(slurp) * 4


def _eat_chips(rng, n):
    crack = _crunches(rng, n, rng.uniform(250, 450), 2500, 12000, 0.0008)
    crack *= 0.4 + 0.6 * np.clip(np.sin(2 * np.pi * rng.uniform(1.5, 2.5) * _t(n)), 0, 1)
    rustle = _band(_noise(rng, n), 4000, 14000) * _smooth_random(rng, n, 40, 0.95) ** 2
    return crack / (np.std(crack) + 1e-12) + rng.uniform(0.2, 0.6) * rustle / (np.std(rustle) + 1e-12)


# ----------------------------------------------------------------------------- washing
def _wash_hands(rng, n):
    water = _water(rng, n, 500, 7000, rng.uniform(40, 80))
    rub = _band(_noise(rng, n), 300, 2000) * (0.5 + 0.5 * np.sin(2 * np.pi * rng.uniform(2.5, 4) * _t(n)))
    return water + rng.uniform(0.3, 0.8) * rub


def _wash_clothes(rng, n):
    t = _t(n)
    drum = rng.uniform(0.6, 1.2)
    slosh = _band(_noise(rng, n), 100, 1200) * (0.4 + 0.6 * np.sin(2 * np.pi * drum * t) ** 2)
    hum = _motor(rng, n, rng.choice([50.0, 60.0]) * rng.uniform(0.95, 1.05), 6, 0.002)
    thump = _place(n, rng, lambda: _ring(rng, 4000, [rng.uniform(40, 70)], 0.05), (1 / drum * 0.9, 1 / drum * 1.1))
    return slosh + 0.25 * hum + 0.8 * _norm(thump) * 2


def _wash_dishes(rng, n):
    water = _water(rng, n, 400, 5000, rng.uniform(30, 60))
    clinks = _place(n, rng, lambda: _ring(rng, int(0.3 * SR), [rng.uniform(1800, 3000), rng.uniform(4000, 6500),
                                                              rng.uniform(7000, 9000)], rng.uniform(0.04, 0.1), 0.05),
                    (0.2, 0.6))
    return water + 3 * clinks


# ----------------------------------------------------------------------------- appliances and tools
def _use_scissor(rng, n):
    def snip():
        m = int(0.12 * SR)
        slide = _band(_noise(rng, m), 3000, 9000) * np.linspace(0.2, 1, m) ** 2 * 0.4
        click = _ring(rng, m, [rng.uniform(3500, 5500), rng.uniform(6500, 8500)], 0.015, 0.05)
        click = np.roll(click, int(0.09 * SR)) * (np.arange(m) > 0.09 * SR)
        return slide + click
    return _place(n, rng, snip, (0.2, 0.4))


def _use_blender(rng, n):
    f0 = rng.uniform(150, 280)
    m = _motor(rng, n, f0, 20, 0.04, 0.85)
    grind = _band(_noise(rng, n), 500, 8000) * _smooth_random(rng, n, 15, 0.5)
    return _norm(m) + rng.uniform(0.2, 0.5) * _norm(grind) * 3


def _use_stove(rng, n):
    roar = _band(_noise(rng, n), rng.uniform(80, 150), rng.uniform(1500, 2500))
    roar *= _smooth_random(rng, n, 8, 0.15)
    out = roar / np.std(roar)
    if rng.random() < 0.7:  # igniter clicks
        out += _place(n, rng, lambda: 8 * _ring(rng, 800, [rng.uniform(3000, 5000)], 0.003), (0.12, 0.2),
                      first=(0, 0.2)) * (np.arange(n) < rng.uniform(0.5, 1.2) * SR)
    return out


def _use_hair_dryer(rng, n):
    air = _band(_noise(rng, n), 300, 12000)
    whine = _motor(rng, n, rng.uniform(450, 750), 5, 0.01, 0.6)
    return air / np.std(air) + rng.uniform(0.5, 1.2) * whine


def _use_microwave(rng, n):
    hum = _motor(rng, n, rng.choice([100.0, 120.0]), 10, 0.002, 0.75)
    fan = _band(_noise(rng, n), 200, 3000)
    out = hum + rng.uniform(0.2, 0.5) * fan / np.std(fan)
    if rng.random() < 0.4:  # the end-of-cooking beep
        m = int(0.25 * SR)
        beep = np.sin(2 * np.pi * rng.uniform(1800, 2600) * _t(m)) * 1.5
        p = int(rng.uniform(0.1, 1.5) * SR)
        out[p:p + m] += beep[:n - p]
    return out


def _use_fan(rng, n):
    t = _t(n)
    blade = rng.uniform(12, 25)
    air = _band(_noise(rng, n), 60, rng.uniform(700, 1400)) * (1 + 0.4 * np.sin(2 * np.pi * blade * t))
    return air + 0.1 * _motor(rng, n, rng.uniform(80, 120), 3, 0.005) * np.std(air)


def _watch_tv(rng, n):
    t = _t(n)
    f0 = rng.uniform(100, 220) * _smooth_random(rng, n, 4, 0.25)
    syl = np.clip(np.sin(2 * np.pi * rng.uniform(3.5, 5.5) * t + rng.uniform(0, 6.3)), 0, 1)
    f1 = rng.uniform(500, 800)
    speech = _voiced(rng, f0, [(f1, 300, 1.0), (rng.uniform(1300, 2000), 500, 0.6), (2600, 600, 0.3)], 0.2) * syl
    fric = _band(_noise(rng, n), 3000, 7000) * (np.clip(np.sin(2 * np.pi * 2.3 * t + 1), 0.8, 1) - 0.8) * 3
    music = 0
    if rng.random() < 0.6:
        root = rng.uniform(110, 220)
        music = sum(np.sin(2 * np.pi * root * r * t) for r in (1, 1.26, 1.5)) * 0.15 * np.std(speech) * 4
    mix = _norm(speech) + 0.2 * fric + music
    return _band(mix, 150, 7000)  # a TV speaker


def _type_keyboard(rng, n):
    def key():
        m = int(0.03 * SR)
        c = _band(_noise(rng, m), rng.uniform(1500, 2500), 9000) * _env(m, 0.0005, 0.004)
        body = 0.5 * _ring(rng, m, [rng.uniform(250, 450)], 0.01)
        return c + body
    return _place(n, rng, key, (0.06, 0.22), first=(0, 0.1))


def _cut_food(rng, n):
    def chop():
        m = int(0.15 * SR)
        board = _ring(rng, m, [rng.uniform(250, 450), rng.uniform(700, 1100)], rng.uniform(0.02, 0.04), 0.05)
        tick = 0.4 * _band(_noise(rng, m), 2000, 8000) * _env(m, 0.0005, 0.003)
        return board + tick
    return _place(n, rng, chop, (0.18, 0.33))


def _fry_food(rng, n):
    hiss = _band(_noise(rng, n), 3000, 14000) * _smooth_random(rng, n, 10, 0.3)
    pops = _crunches(rng, n, rng.uniform(300, 800), 1500, 12000, 0.0005)
    return hiss / np.std(hiss) * rng.uniform(0.3, 0.7) + pops / (np.std(pops) + 1e-12)


def _pour_water(rng, n):
    f = np.linspace(rng.uniform(300, 500), rng.uniform(1200, 2000), n)  # the glass fills: pitch rises
    x = _band(_noise(rng, n), 200, 8000)
    out = np.zeros(n)
    step = 1024
    for i in range(0, n, step):
        seg = x[i:i + step + 512]
        out[i:i + step] = _band(seg, f[i] * 0.85, f[i] * 1.15)[:len(out[i:i + step])]
    splash = _water(rng, n, 800, 6000, 30) * 0.1
    return out / (np.std(out) + 1e-12) + splash


def _shave(rng, n):
    buzz = np.sign(np.sin(2 * np.pi * np.cumsum(rng.uniform(100, 130) * _smooth_random(rng, n, 2, 0.03)) / SR))
    buzz = _band(buzz, 80, 6000)
    cut = _band(_noise(rng, n), 2000, 8000) * (0.3 + 0.7 * np.clip(np.sin(2 * np.pi * rng.uniform(1, 2.5) * _t(n)), 0, 1))
    return buzz + rng.uniform(0.1, 0.3) * cut


def _brush_teeth(rng, n):
    t = _t(n)
    rate = rng.uniform(3, 5)
    stroke = np.abs(np.sin(2 * np.pi * rate * t + rng.uniform(0, 6.3))) ** 1.5
    scrub = _band(_noise(rng, n), rng.uniform(1500, 2500), rng.uniform(7000, 10000)) * stroke
    foam = 0.2 * _band(_noise(rng, n), 300, 1200) * _smooth_random(rng, n, 20, 0.8)
    return scrub + foam


def _flush_toilet(rng, n):
    rush = _water(rng, n, 150, 5000, rng.uniform(80, 140))
    start = rng.uniform(-0.5, 0.3)
    t = _t(n) - start
    env = np.where(t < 0, 0.05, np.exp(-np.maximum(t, 0) / rng.uniform(1.5, 3.0)) * 0.8 + 0.2)
    gurgle = _band(_noise(rng, n), 60, 400) * _smooth_random(rng, n, 20, 0.9) * 2
    return (rush + gurgle) * env


def _do_nothing(rng, n):
    return np.zeros(n)  # only the room tone / background added in :func:`render`


GENERATORS: dict[str, Callable[[Rng, int], np.ndarray]] = {
    "cough": _cough, "cry": _cry, "clear throat": _clear_throat, "sneeze": _sneeze, "sniff": _sniff,
    "fall down": _fall_down, "burp": _burp, "yawn": _yawn, "snore": _snore,
    "drink water": _drink_water, "drink milk": _drink_milk, "drink soup": _drink_soup,
    "eat apple": _eat_apple, "eat noodle": _eat_noodle, "eat chips": _eat_chips,
    "wash hands": _wash_hands, "wash clothes": _wash_clothes, "wash dishes": _wash_dishes,
    "use scissor": _use_scissor, "use blender": _use_blender, "use stove": _use_stove,
    "use hair dryer": _use_hair_dryer, "use microwave": _use_microwave, "use fan": _use_fan,
    "watch TV": _watch_tv, "type keyboard": _type_keyboard, "cut food": _cut_food,
    "fry food": _fry_food, "pour water into glass": _pour_water, "shave": _shave,
    "brush teeth": _brush_teeth, "flush toilet": _flush_toilet, "do nothing": _do_nothing,
}
assert tuple(GENERATORS) == spaces.ACTIVITIES


# ----------------------------------------------------------------------------- the room
def room_impulse(rng: Rng) -> np.ndarray:
    """A random room: exponentially decaying noise tail, RT60 0.15-0.7 s, a few early reflections."""
    rt60 = rng.uniform(0.15, 0.7)
    m = int(rt60 * SR)
    t = _t(m)
    ir = _noise(rng, m) * np.exp(-6.9 * t / rt60)
    ir = _band(ir, 100, rng.uniform(4000, 10000))
    ir /= np.sqrt(np.sum(ir ** 2)) + 1e-12
    ir *= rng.uniform(0.2, 0.6)  # wet level
    ir[0] += 1.0  # direct sound
    for _ in range(3):
        ir[rng.integers(int(0.003 * SR), int(0.03 * SR))] += rng.uniform(0.1, 0.4)
    return ir


def background(rng: Rng, n: int) -> np.ndarray:
    """Room tone: pink noise, sometimes mains hum and a faint distant sound, unit scale."""
    bg = _band(_pink(rng, n), 30, rng.uniform(3000, 9000))
    bg /= np.std(bg) + 1e-12
    if rng.random() < 0.4:
        bg += rng.uniform(0.1, 0.5) * _motor(rng, n, rng.choice([50.0, 60.0]), 3, 0.001)
    if rng.random() < 0.3:  # distant traffic rumble
        bg += rng.uniform(0.5, 1.5) * _band(_noise(rng, n), 20, 200) * 3
    return bg / (np.std(bg) + 1e-12)


def render(activity: str, rng: Rng, seconds: float = 2.0) -> np.ndarray:
    """One synthetic clip of ``activity`` (a Table I name): mono float32 at 32 kHz.

    The dry source is scaled to a random level (-30 to -14 dBFS RMS), convolved with a random room
    and mixed with room tone at a random signal-to-noise ratio (10-35 dB). "do nothing" is room
    tone alone, at -60 to -44 dBFS RMS.
    """
    name = spaces.canonical("activity", activity)
    n = int(seconds * SR)
    dry = GENERATORS[name](rng, n)
    bg = background(rng, n)
    if name == "do nothing":
        y = bg * 10 ** (rng.uniform(-60, -44) / 20)
    else:
        dry = dry / (np.sqrt(np.mean(dry ** 2)) + 1e-12)
        wet = sps.fftconvolve(dry, room_impulse(rng))[:n]
        level = 10 ** (rng.uniform(-30, -14) / 20)
        wet = wet / (np.sqrt(np.mean(wet ** 2)) + 1e-12) * level
        snr = rng.uniform(10, 35)
        y = wet + bg * level * 10 ** (-snr / 20)
    peak = np.max(np.abs(y))
    if peak > 0.98:
        y *= 0.98 / peak
    return y.astype(np.float32)
