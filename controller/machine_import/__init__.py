"""Machine files from the configurations users already have: a LinuxCNC INI
(:mod:`.linuxcnc_ini`) or a grbl ``$$`` dump (:mod:`.grbl_settings`). Pure parsing and mapping,
numbers only: the model's masses and joint ranges come in as a :class:`~.common.Target`, and the
result (:class:`~.common.Imported`) is written as TOML by :mod:`.machine_toml`.
"""
