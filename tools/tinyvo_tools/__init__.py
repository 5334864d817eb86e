"""tinyvo's Python tools. Each module is a command: python -m tinyvo_tools.<module> --help."""
__version__ = "0.1.0"
