"""The one error type users see for bad pipeline input (defined with the other located errors)."""

from __future__ import annotations

from citylearn_env.errors import InputError

__all__ = ["InputError"]
