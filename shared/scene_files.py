"""Loading a scene file, and the shipped scenes by name.

`load_scene` validates a scene file and the files it refers to (the robot description, its arm's
URDF, objects' URDFs) where the world will look for them. A shipped scene is named by its file's
stem (`scene_path("flat")`); the generated houses robocog ships (`assets/scenes/generated/`) are named
the same way (`scene_path("house-007")`).
"""

from __future__ import annotations

from pathlib import Path

from robocog.assets import ASSETS_DIR
from robocog.shared.config_files import load_yaml_model
from robocog.shared.errors import ConfigError
from robocog.shared.robot_spec import load_robot, outside_problem, resolve_urdf, shipped_folders, urdf_problem
from robocog.shared.scene import Scene
from robocog.shared.scene_bounds import SCENE_FILE_BYTES


def load_scene(path: Path) -> Scene:
    """Load and validate a scene file, and the robot description and URDFs it refers to.

    The file is within the bounds of `robocog.shared.scene_bounds` (its size, its counts, every number),
    and every file it names lies in the scene's own folder, robocog's assets or pybullet_data (links
    followed): anything else is refused, unread, with a `ConfigError` of one line.
    """
    scene = load_yaml_model(path, Scene, max_bytes=SCENE_FILE_BYTES)
    folders = (path.parent, *shipped_folders())
    robot = scene.robot_file()
    problem = outside_problem(scene.robot, robot, folders)
    if problem is not None:
        raise ConfigError(f"{path}: robot: {problem}")
    if not robot.is_file():
        raise ConfigError(f"{path}: robot: {scene.robot!r}: no such file (robot files are relative to {ASSETS_DIR})")
    load_robot(robot, folders)
    for i, obj in enumerate(scene.objects):
        if obj.urdf is None:
            continue
        problem = urdf_problem(obj.urdf) or outside_problem(obj.urdf, resolve_urdf(obj.urdf), folders)
        if problem is not None:
            raise ConfigError(f"{path}: objects[{i}].urdf: {problem}")
    return scene


#: Where the shipped scenes live; a scene is named by its file's stem.
SCENES_DIR = ASSETS_DIR / "scenes"
#: Where the generated houses robocog ships live (`robocog.agent.housegen`), also named by stem.
GENERATED_DIR = SCENES_DIR / "generated"


def scene_names() -> list[str]:
    """The shipped scenes' names, sorted (the generated houses are `generated_scene_names`)."""
    return sorted(p.stem for p in SCENES_DIR.glob("*.yaml"))


def generated_scene_names() -> list[str]:
    """The generated houses robocog ships, sorted: house-000 ... house-049."""
    return sorted(p.stem for p in GENERATED_DIR.glob("*.yaml"))


def scene_path(scene: str | Path) -> Path:
    """The file of a scene given by name ('flat' -> assets/scenes/flat.yaml) or by path (kept as it is).

    A bare word (no directory, no suffix) that is not an existing file is a name; an unknown name is
    a `ConfigError` listing the known ones. A path is returned unchanged (`load_scene` checks it).
    """
    path = Path(scene)
    text = str(scene)
    if path.is_file() or path.suffix or "/" in text or "\\" in text:
        return path
    for folder in (SCENES_DIR, GENERATED_DIR):
        named = folder / f"{text}.yaml"
        if named.is_file():
            return named
    houses = generated_scene_names()
    generated = f", and the generated houses {houses[0]} ... {houses[-1]}" if houses else ""
    raise ConfigError(
        f"scene {text!r}: no such scene; known scenes: {', '.join(scene_names())}{generated} "
        "(or give the path of a scene YAML)"
    )
