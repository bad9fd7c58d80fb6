"""Gives a Mitsuba scene file the settings of `cargo xtask mitsuba`'s comparison.

The XML mode of `cargo xtask mitsuba` (xtask/src/mitsuba/) renders a Mitsuba
scene file itself rather than an export of our scene. `mitsuba_pt.py --original`
calls `prepare` before every render; usable alone too:

    python mitsuba_xml.py scenes/veach-mis/scene.xml target/mitsuba/mitsuba-xml/scene.xml \
        --width 160 --height 120 --spp 64 --max-depth 8

What it changes, in a copy (every other element is kept as it is, comments too):
- `<include>` elements are replaced by the children of the files they name
  (recursively), so that a sensor or integrator inside a fragment is found;
- every top-level `<integrator>` by one `path` integrator with the comparison's
  max_depth and rr_depth = 3 (as the export writes it: see export.rs);
- in every `<sensor>`, the `<sampler>` by the comparison's sampler with
  sample_count = spp, and the `<film>` by an `hdrfilm` of the comparison's
  size, `pixel_format` rgb and a `box` reconstruction filter (our only one).
  Crop windows, other filters and LDR films would not compare.

Elements are replaced rather than their `$param` `<default>` values changed, so
a file whose film size or sample count is a literal gets them too; defaults
that the replaced elements used stay, unused, which Mitsuba allows. Property
names follow the file's version: camelCase (`maxDepth`, `sampleCount`) for
Mitsuba 0.x files (version < 2), which Mitsuba 3 upgrades when it loads them,
snake_case otherwise.

The copy is written without the scene's folder, so Mitsuba must find the files
the scene names (meshes, textures) through its file resolver: `mitsuba_pt.py`
prepends the original file's folder, and `prepare` returns that folder.
"""

import argparse
import pathlib
import sys
import xml.etree.ElementTree as ET

# Roulette from the third vertex on, as the export's integrator (export.rs).
RR_DEPTH = 3


class SceneError(Exception):
    """A scene file this module cannot prepare."""


def parse(path):
    """The element tree of `path`, with comments kept."""
    parser = ET.XMLParser(target=ET.TreeBuilder(insert_comments=True))
    try:
        return ET.parse(path, parser=parser)
    except (ET.ParseError, OSError) as e:
        raise SceneError(f"{path}: {e}") from e


def is_legacy(root):
    """Whether `root` is a Mitsuba 0.x scene (camelCase property names)."""
    version = root.get("version", "")
    try:
        return int(version.split(".")[0]) < 2
    except ValueError:
        return False


def expand_includes(root, scene_dir, depth=0):
    """Replaces every `<include filename=...>` under `root` by the children of
    the file it names, looked up next to the scene file (as Mitsuba's file
    resolver does with the scene's folder first)."""
    if depth > 16:
        raise SceneError("includes nested more than 16 deep (a cycle?)")
    for parent in list(root.iter()):
        for index, child in reversed(list(enumerate(parent))):
            if child.tag != "include":
                continue
            name = child.get("filename", "")
            path = scene_dir / name
            if not name or not path.is_file():
                raise SceneError(f"<include filename=\"{name}\">: no such file in {scene_dir}")
            included = parse(path).getroot()
            if is_legacy(included) != is_legacy(root):
                raise SceneError(
                    f"{name} has version {included.get('version')} and the scene "
                    f"{root.get('version')}: files of Mitsuba 0.x and 2+ cannot be merged"
                )
            expand_includes(included, scene_dir, depth + 1)
            parent.remove(child)
            for offset, grandchild in enumerate(list(included)):
                parent.insert(index + offset, grandchild)
            if len(included) > 0:
                included[-1].tail = child.tail


def element(tag, plugin, properties, names):
    """`<tag type=plugin>` with `(kind, snake_name, value)` properties and any
    child elements given as `ET.Element`s."""
    e = ET.Element(tag, {"type": plugin})
    for p in properties:
        if isinstance(p, ET.Element):
            e.append(p)
        else:
            kind, name, value = p
            ET.SubElement(e, kind, {"name": names(name), "value": str(value)})
    return e


def replace(parent, old, new):
    """Puts `new` where `old` was (same tail, and id if it had one)."""
    index = list(parent).index(old)
    new.tail = old.tail
    if old.get("id") is not None:
        new.set("id", old.get("id"))
    parent.remove(old)
    parent.insert(index, new)


def indent_unit(root):
    """The file's indentation step (the whitespace before its first element)."""
    unit = (root.text or "").rsplit("\n", 1)[-1]
    return unit if unit and not unit.strip() else "\t"


def prepare(original, prepared, *, width, height, spp, max_depth, sampler="independent"):
    """Writes `original` with the comparison's settings to `prepared`; returns
    the folder to put on Mitsuba's file resolver and a summary (dict)."""
    original = pathlib.Path(original).resolve()
    scene_dir = original.parent
    tree = parse(original)
    root = tree.getroot()
    if root.tag != "scene":
        raise SceneError(f"{original}: the root element is <{root.tag}>, not <scene>")
    legacy = is_legacy(root)
    camel = {
        "max_depth": "maxDepth",
        "rr_depth": "rrDepth",
        "sample_count": "sampleCount",
        "pixel_format": "pixelFormat",
    }

    def names(snake):
        return camel.get(snake, snake) if legacy else snake

    expand_includes(root, scene_dir)

    integrator = element(
        "integrator",
        "path",
        [("integer", "max_depth", max_depth), ("integer", "rr_depth", RR_DEPTH)],
        names,
    )
    unit = indent_unit(root)
    integrators = root.findall("integrator")
    replaced = [i.get("type") for i in integrators]
    if integrators:
        replace(root, integrators[0], integrator)
        for extra in integrators[1:]:
            root.remove(extra)
    else:
        # After the <default> elements, which must come before their use.
        first = next((i for i, c in enumerate(root) if c.tag != "default"), len(root))
        integrator.tail = "\n" + unit
        root.insert(first, integrator)
    ET.indent(integrator, space=unit, level=1)

    sensors = root.findall("sensor")
    if not sensors:
        raise SceneError(
            f"{original}: no <sensor> at the top level (Mitsuba's default camera "
            "is not one our loader knows)"
        )
    for sensor in sensors:
        new_sampler = element("sampler", sampler, [("integer", "sample_count", spp)], names)
        new_film = element(
            "film",
            "hdrfilm",
            [
                ("integer", "width", width),
                ("integer", "height", height),
                ("string", "pixel_format", "rgb"),
                ET.Element("rfilter", {"type": "box"}),
            ],
            names,
        )
        for tag, new in (("sampler", new_sampler), ("film", new_film)):
            old = sensor.findall(tag)
            if old:
                replace(sensor, old[0], new)
                for extra in old[1:]:
                    sensor.remove(extra)
            elif len(sensor):
                new.tail = sensor[-1].tail
                sensor[-1].tail = sensor.text
                sensor.append(new)
            else:
                sensor.text, new.tail = "\n" + unit * 2, "\n" + unit
                sensor.append(new)
            ET.indent(new, space=unit, level=2)

    prepared = pathlib.Path(prepared)
    prepared.parent.mkdir(parents=True, exist_ok=True)
    tree.write(prepared, encoding="utf-8", xml_declaration=True)
    summary = {
        "original": str(original),
        "prepared": str(prepared),
        "version": root.get("version"),
        "legacy_names": legacy,
        "integrators_replaced": replaced,
        "sensors": len(sensors),
    }
    return scene_dir, summary


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("original", help="Mitsuba scene file")
    parser.add_argument("prepared", help="where to write the copy")
    parser.add_argument("--width", type=int, required=True)
    parser.add_argument("--height", type=int, required=True)
    parser.add_argument("--spp", type=int, required=True)
    parser.add_argument("--max-depth", type=int, required=True)
    parser.add_argument("--sampler", default="independent")
    args = parser.parse_args()
    try:
        _, summary = prepare(
            args.original,
            args.prepared,
            width=args.width,
            height=args.height,
            spp=args.spp,
            max_depth=args.max_depth,
            sampler=args.sampler,
        )
    except SceneError as e:
        print(f"mitsuba_xml.py: {e}", file=sys.stderr)
        sys.exit(1)
    print(summary)


if __name__ == "__main__":
    main()
