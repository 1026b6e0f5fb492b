"""omniloc: absolute localization of a mobile robot from unlabelled landmark bearings."""

from __future__ import annotations

import logging

__version__ = "0.1.0"

logging.getLogger(__name__).addHandler(logging.NullHandler())
