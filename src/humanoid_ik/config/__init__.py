"""Files a user writes: scene files (``scene``, the values in ``specs``) and sweep files
(``sweep_file``), both read by the one TOML reader of ``toml``."""
