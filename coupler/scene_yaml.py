"""scene_yaml.py — a scene's YAML read by Python as the C reader reads it.

PyYAML follows YAML 1.1, where a float needs a point and a signed exponent:
it read 1e-5, 5E3 and 1.0e3 as strings, and inf and nan too, while the C
reader (common/scene_check.c, number_prefix) and models/README.md take them as
numbers. coupler/plot.py then failed on a valid scene (`radius: 5e-5`: "can't
multiply sequence by non-int"). load() adds those forms to PyYAML's floats;
everything else is read as yaml.safe_load reads it."""
import re

import yaml


class SceneLoader(yaml.SafeLoader):
    """yaml.SafeLoader with the numbers of a scene that YAML 1.1 leaves as text."""


SceneLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)[eE][-+]?[0-9]+$|^[-+]?(?:inf|infinity|nan)$", re.IGNORECASE),
    list("-+0123456789.iInN"))


def load(text):
    """The scene text (a file's or an output's `scene` attribute) as Python objects."""
    return yaml.load(text, Loader=SceneLoader)
