"""The SimBuild 2024 paper's 17 control benchmarks on any district: :mod:`.benchmarks` (one run), :mod:`.tasks`
(the whole paper as resumable tasks), :mod:`.results` (tables), :mod:`.figures`, :mod:`.sac` (SAC back ends)."""
