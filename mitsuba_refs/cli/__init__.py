"""``mitsuba-refs``: the entry point and ``build`` in ``main``, and one module per other
command (``compare``, ``check``, ``report``). Empty, so that importing one command does not
start the others."""
