"""``nhsim bench render``: video pipeline frames/s against a bare Renderer loop (see
:mod:`sim.tools.bench.render`)."""

from __future__ import annotations

import argparse


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Options of the benchmark."""
    p.add_argument("--size", default="640x480", metavar="WxH", help="frame size (default: 640x480)")
    p.add_argument("--quality", choices=["fast", "high"], default="fast", help="render look (default: fast)")
    p.add_argument("--camera", choices=["overview", "chase"], default="overview", help="camera (default: overview)")
    p.add_argument("--frames", type=int, default=300, metavar="N", help="frames per loop, at least 100 (default: 300)")
    p.add_argument("--repeats", type=int, default=3, metavar="N", help="alternating rounds, best counts (default: 3)")
    p.add_argument("--gl", choices=["osmesa", "egl", "glfw"], default=None, help="OpenGL backend")


def run(args: argparse.Namespace) -> int:
    """Measure and print; exit 1 when a target is missed."""
    from sim.viz import gl

    backend = gl.configure(args.gl)  # before anything imports mujoco
    from sim.tools.bench.render import TARGET_FPS, TARGET_RATIO, measure

    r = measure(args.size, args.camera, args.quality, args.frames, args.repeats)
    capped = f" (of the {args.frames} asked for: the replay has no more)" if r.frames < args.frames else ""
    print(
        f"{r.width}x{r.height}, {r.quality} look, {r.camera} camera, GL {backend}, {r.frames} frames{capped}, "
        f"best of {r.repeats}"
    )
    print(f"bare Renderer loop       {r.bare_fps:>8.1f} frames/s   (update_scene + render)")
    how = "world drawn once, robots composited" if r.composited else "full scene every frame"
    what = f"replay, ghosts, lines, inset, text, H.264; {how}"
    print(f"video pipeline           {r.pipeline_fps:>8.1f} frames/s   ({what})")
    print(f"ratio                    {r.ratio:>8.3f}            (target >= {TARGET_RATIO})")
    print(
        f"pipeline frame rate      {r.pipeline_fps:>8.1f} frames/s   (target >= {TARGET_FPS:g} at 640x480, fast look)"
    )
    ms = 1e3 / r.frames
    print(
        f"CPU per frame            bare {r.bare_cpu_s * ms:.2f} ms, pipeline {r.pipeline_cpu_s * ms:.2f} ms "
        f"(encoder {r.encoder_cpu_s * ms:.2f} ms); bare / pipeline {r.cpu_ratio:.3f}: the ratio's bound when the "
        "rasteriser keeps every core busy"
    )
    print(f"targets                  {'met' if r.passed else 'missed'}")
    return 0 if r.passed else 1
