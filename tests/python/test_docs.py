"""The documentation against its sources: README.md's table against docs/scene_results.json (the one file of the
molecular scenes' headline numbers), and docs/USER_GUIDE.md's reference section against the public methods of the
headers under openmmapi/include."""
import json
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
RESULTS = json.loads((ROOT / "docs" / "scene_results.json").read_text(encoding="utf-8"))
SCENES = RESULTS["scenes"]

# A number as the docs write it: digits with optional thousands commas and decimals, not part of a word (SWM4) or of
# a longer number; its sign is dropped (the JSON writes −2.0σ as the README does, but signs are not compared here).
NUMBER = re.compile(r"(?<![\w.,])\d{1,3}(?:,\d{3})+(?:\.\d+)?(?![\w,]*\d)|(?<![\w.,])\d+(?:\.\d+)?(?![\d])")


def numbers(text):
    """The numbers of a text, as written (thousands commas removed)."""
    return [match.replace(",", "") for match in NUMBER.findall(text)]


def json_numbers(value):
    """Every number a JSON value holds, in its strings as written and as JSON numbers."""
    if isinstance(value, dict):
        return set().union(*(json_numbers(v) for v in value.values())) if value else set()
    if isinstance(value, list):
        return set().union(*(json_numbers(v) for v in value)) if value else set()
    if isinstance(value, bool) or value is None:
        return set()
    if isinstance(value, (int, float)):
        return {repr(value)}
    return set(numbers(str(value)))


def readme_table():
    """The rows of README.md's table of where the integrators win and lose, as lists of cells."""
    lines = (ROOT / "README.md").read_text(encoding="utf-8").splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("| system | recipe | speed"))
    header = [cell.strip() for cell in re.split(r"(?<!\\)\|", lines[start])[1:-1]]
    rows = []
    for line in lines[start + 2:]:
        if not line.startswith("|"):
            break
        rows.append([cell.strip().replace("\\|", "|") for cell in re.split(r"(?<!\\)\|", line)[1:-1]])
    return header, rows


def scene_of(row):
    """The scene of scene_results.json whose title starts the row's first cell."""
    found = [key for key, scene in SCENES.items() if row[0].lower().startswith(scene["title"].lower())]
    assert len(found) == 1, f"README table row {row[0]!r}: no single scene of scene_results.json has its title"
    return found[0]


def test_the_readme_table_has_at_most_five_rows_of_short_cells():
    header, rows = readme_table()
    assert header == ["system", "recipe", "speed (CPU)", "accuracy", "where it loses"]
    assert 1 <= len(rows) <= 5
    for row in rows:
        assert len(row) == len(header), row
        for cell in row:
            assert len(cell) <= 120, f"README table cell of {len(cell)} characters: {cell}"


def test_every_scene_of_scene_results_has_a_readme_row():
    _, rows = readme_table()
    assert sorted(scene_of(row) for row in rows) == sorted(SCENES)


@pytest.mark.parametrize("row", readme_table()[1], ids=lambda row: row[0])
def test_every_number_of_a_readme_row_is_its_scenes_number_in_scene_results(row):
    scene = SCENES[scene_of(row)]
    allowed = json_numbers(scene)
    for cell in row:
        for number in numbers(cell):
            assert number in allowed, (f"README table, {scene['title']}: {number} in {cell!r} is not a number of "
                                       "docs/scene_results.json's entry for the scene")


@pytest.mark.parametrize("row", readme_table()[1], ids=lambda row: row[0])
def test_a_readme_row_quotes_its_speed_accuracy_and_gpu_as_scene_results_has_them(row):
    scene = SCENES[scene_of(row)]
    _, _, speed, accuracy, loses = row
    assert speed.startswith(scene["speed"]["text"] + " "), (speed, scene["speed"]["text"])
    assert scene["speed"]["platform"] == "CPU" and scene["speed"]["threads"] == 2
    assert accuracy.endswith(scene["accuracy"]["short"]), (accuracy, scene["accuracy"]["short"])
    assert f"{scene['accuracy']['runs']} " in accuracy
    assert loses.endswith("GPU: " + scene["gpu"]["text"]) or ("GPU: " + scene["gpu"]["text"] + " (") in loses
    assert scene["gpu"]["measured"] == (scene["gpu"]["ratio"] is not None)
    if "model_prediction_text" in scene["gpu"]:
        assert scene["gpu"]["model_prediction_text"] + " predicted since, unmeasured" in loses
    assert ("not a win" in row[0]) == (scene["verdict"] == "not a win")


def test_the_readme_names_the_speeds_platform_and_threads():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    assert "CPU platform, 2 threads" in text


def test_scenes_md_quotes_each_speed_and_gpu_ratio_of_scene_results():
    text = (ROOT / "docs" / "SCENES.md").read_text(encoding="utf-8")
    for scene in SCENES.values():
        assert scene["speed"]["text"] in text, scene["speed"]["text"]
        if scene["gpu"]["measured"]:
            assert scene["gpu"]["text"] in text, scene["gpu"]["text"]
        if "model_prediction_text" in scene["gpu"]:
            assert scene["gpu"]["model_prediction_text"] in text


def test_scene_results_names_files_that_exist():
    for scene in SCENES.values():
        for part in ("speed", "accuracy", "gpu"):
            name = scene[part]["file"].replace("seedS", "seed1")
            assert (ROOT / name).exists(), name
        assert (ROOT / scene["scene_readme"]).exists()


HEADERS = {"FlavorIntegrator": "FlavorIntegrator.h", "StochasticImpulseIntegrator": "StochasticImpulseIntegrator.h",
           "FirstOrderFlavor": "FirstOrderFlavor.h"}


def without_bodies(text):
    """text with its comments, brace blocks (function bodies, enums) and constructor initializer lists removed."""
    text = re.sub(r"/\*.*?\*/", " ", text, flags=re.S)
    text = re.sub(r"//[^\n]*", " ", text)
    while True:
        shorter = re.sub(r"\{[^{}]*\}", ";", text)
        if shorter == text:
            break
        text = shorter
    return re.sub(r"\)\s*:[^;]*;", ");", text)


def public_methods(header, name):
    """The names of the public methods (constructors included) that the class name of a header declares."""
    text = (ROOT / "openmmapi" / "include" / header).read_text(encoding="utf-8")
    text = re.sub(r"/\*.*?\*/", " ", text, flags=re.S)
    start = re.search(r"class\s+(?:\w+\s+)?" + name + r"\b[^;{]*\{", text).end()
    depth, end = 1, start
    while depth:
        depth += {"{": 1, "}": -1}.get(text[end], 0)
        end += 1
    body = text[start:end - 1]
    public = "".join(re.split(r"\b(?:private|protected)\s*:", part)[0]
                     for part in re.split(r"\bpublic\s*:", body)[1:])
    names = set()
    for statement in without_bodies(public).split(";"):
        if re.match(r"\s*(?:using|enum|typedef|static\s+constexpr)\b", statement):
            continue
        match = re.search(r"\b(~?\w+)\s*\(", statement)
        if match:
            names.add(match.group(1))
    return names


def reference_section():
    text = (ROOT / "docs" / "USER_GUIDE.md").read_text(encoding="utf-8")
    start = text.index("\n## Reference: constructors, getters and setters\n")
    end = text.find("\n## ", start + 1)
    return text[start:end]


@pytest.mark.parametrize("name", sorted(HEADERS))
def test_the_user_guide_reference_lists_every_public_method_of_the_headers(name):
    methods = public_methods(HEADERS[name], name)
    assert name in methods and len(methods) > 5, methods
    section = reference_section()
    start = section.index(f"\n### {name}")
    end = section.find("\n### ", start + 1)
    listed = set(re.findall(r"`(\w+)\(", section[start:end if end >= 0 else None]))
    missing = sorted(methods - listed)
    assert not missing, f"docs/USER_GUIDE.md's reference section lists no row for {name}::{missing}"


def test_the_public_headers_are_the_ones_the_reference_covers():
    covered = set(HEADERS.values()) | {"FlavorKernels.h"}  # the kernel interfaces: for platforms, not users
    assert {path.name for path in (ROOT / "openmmapi" / "include").glob("*.h")} == covered
