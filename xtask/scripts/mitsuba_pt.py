"""Renders a Mitsuba 3 scene with one variant and sampler and reports timings.

Run by `cargo xtask mitsuba` (xtask/src/mitsuba/), which writes the scene
XML; usable alone too:

    python mitsuba_pt.py --scene scene.xml --out image.exr --spp 64 --seed 1 --threads 2 \
        --variant llvm_ad_rgb --sampler multijitter

Only the render call is timed: "render_s" lists one time per repeat (scene
loading, which builds Mitsuba's BVH, is "load_s"). With an LLVM variant the
first render also compiles its kernels (Dr.Jit caches them on disk, in
~/.drjit, so later processes skip most of it); repeats give the warm time. The last line of standard
output is one JSON object; Mitsuba's log (warnings only) goes to standard
error. Errors are one line on standard error and exit status 1.
"""

import argparse
import json
import pathlib
import sys
import time


def fail(message):
    print(f"mitsuba_pt.py: {message}", file=sys.stderr)
    sys.exit(1)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", required=True, help="Mitsuba scene XML")
    parser.add_argument("--out", required=True, help="output OpenEXR file")
    parser.add_argument("--spp", type=int, required=True, help="samples per pixel")
    parser.add_argument("--seed", type=int, default=0, help="sampler seed")
    parser.add_argument(
        "--repeat", type=int, default=1, help="render this many times (all are timed)"
    )
    parser.add_argument(
        "--threads", type=int, default=0, help="worker threads (0: Mitsuba's default, all cores)"
    )
    parser.add_argument("--variant", default="scalar_rgb", help="Mitsuba variant")
    parser.add_argument(
        "--sampler", default="independent", help="sampler plugin (the XML's $sampler)"
    )
    args = parser.parse_args()

    try:
        import drjit as dr
        import mitsuba as mi
    except ImportError as e:
        fail(f"cannot import mitsuba: {e}")

    try:
        mi.set_variant(args.variant)
    except Exception as e:  # noqa: BLE001 - any failure is reported as one line
        fail(f"variant {args.variant} is not available: {e}")
    # Our coated lobe as a plugin (`rlt_coated`, see rlt_coated.py), which the exporter writes.
    sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
    import rlt_coated  # noqa: F401 - registers the plugin

    # Keep Mitsuba's log (and progress bar) off standard output, which carries the JSON.
    mi.set_log_level(mi.LogLevel.Warn)

    try:
        t0 = time.perf_counter()
        scene = mi.load_file(args.scene, sampler=args.sampler)
        load_s = time.perf_counter() - t0

        # After loading: with one thread set before mi.load_file, Mitsuba
        # 3.9.1 / Dr.Jit 1.5.0 hang in the load (seen on this project's machine).
        if args.threads > 0 and args.threads != dr.thread_count():
            dr.set_thread_count(args.threads)
        threads = dr.thread_count()

        # The same seed every time: the repeats give one image, several times.
        render_s = []
        for _ in range(max(1, args.repeat)):
            t0 = time.perf_counter()
            image = mi.render(scene, spp=args.spp, seed=args.seed)
            # The LLVM variants record the render lazily: evaluate it and
            # wait for it inside the timed region (no-ops in scalar variants).
            dr.eval(image)
            dr.sync_thread()
            render_s.append(time.perf_counter() - t0)

        # Mitsuba 3.9.1 / Dr.Jit 1.5.0 also hang writing an EXR with a pool of
        # one thread: write with at least two.
        if dr.thread_count() < 2:
            dr.set_thread_count(2)
        mi.Bitmap(image).write(args.out)
    except Exception as e:  # noqa: BLE001 - any failure is reported as one line
        fail(str(e).strip().splitlines()[-1] if str(e).strip() else repr(e))

    film = scene.sensors()[0].film()
    width, height = film.size()
    integrator = scene.integrator()
    print(
        json.dumps(
            {
                "mitsuba_version": mi.__version__,
                "drjit_version": dr.__version__,
                "variant": mi.variant(),
                "sampler": str(scene.sensors()[0].sampler()).split("[")[0],
                "threads": threads,
                "integrator": str(integrator).replace("\n", " "),
                "width": int(width),
                "height": int(height),
                "spp": args.spp,
                "seed": args.seed,
                "load_s": load_s,
                "render_s": render_s,
                "out": args.out,
            }
        )
    )


if __name__ == "__main__":
    main()
