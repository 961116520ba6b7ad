"""Ideal-load-variation data and per-building LSTM indoor-temperature surrogates."""
