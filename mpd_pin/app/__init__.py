"""The application: scenario files, the runner (plan → verify → write), result files, the CLI.

``mpd-pin run`` is :func:`mpd_pin.app.cli.main`; a scenario file is parsed by
:mod:`mpd_pin.app.scenario` and run by :mod:`mpd_pin.app.runner`.
"""
