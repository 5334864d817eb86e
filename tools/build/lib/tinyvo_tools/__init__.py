# SPDX-License-Identifier: Apache-2.0
"""tinyvo's Python tools. Each program is a console script (tinyvo-synth, tinyvo-eval, ...; tools/pyproject.toml),
also runnable as python -m tinyvo_tools.<module>; every one has --help."""
__version__ = "0.2.0"
