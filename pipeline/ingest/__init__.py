"""Readers and parsers for raw inputs (EULP, weather, tariff, fuel mix)."""
