"""The SAC back ends of the paper's learning benchmarks: :mod:`.train` (one entry point), :mod:`.lean`
(torch), :mod:`.fast` (hand-written gradients)."""
