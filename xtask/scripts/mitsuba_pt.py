"""Renders a Mitsuba 3 scene with one variant and sampler and reports timings.

Run by `cargo xtask mitsuba` (xtask/src/mitsuba/), which writes the scene
XML; usable alone too:

    python mitsuba_pt.py --scene scene.xml --out image.exr --spp 64 --seed 1 --threads 2 \
        --variant llvm_ad_rgb --sampler multijitter

XML mode (a Mitsuba scene file of its own, `cargo xtask mitsuba --scene x.xml`):
with `--original FILE`, the script first writes FILE with the comparison's
settings (`--width`, `--height`, `--max-depth`, `--spp`, `--sampler`; see
mitsuba_xml.py) to the `--scene` path, puts FILE's folder on Mitsuba's file
resolver (so its relative mesh and texture paths resolve) and loads the copy:

    python mitsuba_pt.py --original scenes/veach-mis/scene.xml --scene /tmp/m/scene.xml \
        --width 160 --height 120 --max-depth 8 --out /tmp/m/image.exr --spp 64 --seed 1

`--load-only` stops after loading (the JSON line then has no render times).

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
    parser.add_argument(
        "--original", help="XML mode: the Mitsuba scene file to render (--scene: its copy)"
    )
    parser.add_argument("--width", type=int, help="XML mode: film width")
    parser.add_argument("--height", type=int, help="XML mode: film height")
    parser.add_argument("--max-depth", type=int, help="XML mode: the path integrator's max_depth")
    parser.add_argument("--load-only", action="store_true", help="load the scene, do not render")
    args = parser.parse_args()
    if args.original and None in (args.width, args.height, args.max_depth):
        fail("--original needs --width, --height and --max-depth")

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

    # The exported scene takes the sampler as $sampler; a scene file of its
    # own gets it written in (Mitsuba refuses parameters a file does not use).
    load_params = {"sampler": args.sampler}
    if args.original:
        import mitsuba_xml

        try:
            scene_dir, _ = mitsuba_xml.prepare(
                args.original,
                args.scene,
                width=args.width,
                height=args.height,
                spp=args.spp,
                max_depth=args.max_depth,
                sampler=args.sampler,
            )
        except mitsuba_xml.SceneError as e:
            fail(str(e))
        # Mitsuba 3.9 has one resolver for all threads; older versions one per thread.
        if hasattr(mi, "file_resolver"):
            resolver = mi.file_resolver()
        else:
            resolver = mi.Thread.thread().file_resolver()
        resolver.prepend(str(scene_dir))
        load_params = {}

    # Keep Mitsuba's log (and progress bar) off standard output, which carries the JSON.
    mi.set_log_level(mi.LogLevel.Warn)

    try:
        t0 = time.perf_counter()
        scene = mi.load_file(args.scene, **load_params)
        load_s = time.perf_counter() - t0

        # After loading: with one thread set before mi.load_file, Mitsuba
        # 3.9.1 / Dr.Jit 1.5.0 hang in the load (seen on this project's machine).
        if args.threads > 0 and args.threads != dr.thread_count():
            dr.set_thread_count(args.threads)
        threads = dr.thread_count()

        # The same seed every time: the repeats give one image, several times.
        render_s = []
        for _ in range(0 if args.load_only else max(1, args.repeat)):
            t0 = time.perf_counter()
            image = mi.render(scene, spp=args.spp, seed=args.seed)
            # The LLVM variants record the render lazily: evaluate it and
            # wait for it inside the timed region (no-ops in scalar variants).
            dr.eval(image)
            dr.sync_thread()
            render_s.append(time.perf_counter() - t0)

        # Mitsuba 3.9.1 / Dr.Jit 1.5.0 also hang writing an EXR with a pool of
        # one thread: write with at least two.
        if not args.load_only:
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
                "out": None if args.load_only else args.out,
                "scene": args.scene,
                "original": args.original,
            }
        )
    )


if __name__ == "__main__":
    main()
