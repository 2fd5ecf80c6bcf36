"""Scene: the TOML problem description, validated once, and the knees it names.

Owns the schema, loading and overrides, knee landmark presets, the knee surfaces and
ligament bundles read from files, and the shared constants. Imports only
`fecheck.errors` and `geometry`.
"""

from fecheck.scene.load import (
    Scene,
    apply_overrides,
    load_scene,
    packaged_scene_path,
    parse_override,
    validate,
    with_values,
)
from fecheck.scene.schema import SCHEMA, Key

__all__ = ["SCHEMA", "Key", "Scene", "apply_overrides", "load_scene", "packaged_scene_path",
           "parse_override", "validate", "with_values"]
