"""Sphinx configuration of the sb3-reinforce documentation (SB3's convention: Sphinx and the Read the Docs theme)."""

import os
import sys

sys.path.insert(0, os.path.abspath(".."))

from sb3_reinforce.version import __version__

project = "sb3-reinforce"
author = "sb3-reinforce contributors"
copyright = "sb3-reinforce contributors, MIT license"
version = release = __version__

extensions = ["sphinx.ext.autodoc", "sphinx.ext.viewcode", "myst_parser"]
# Markdown pages (MyST), with (label)= targets, {ref}/{doc} roles and ```{eval-rst} blocks for autodoc
source_suffix = {".md": "markdown"}
myst_heading_anchors = 3
autodoc_member_order = "bysource"
autodoc_typehints = "description"
exclude_patterns = ["_build"]
html_theme = "sphinx_rtd_theme"
html_title = f"sb3-reinforce {release}"
