"""Packaged data files (emission factors). A package so that the CSV ships in wheels."""
