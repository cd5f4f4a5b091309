"""The command lines: each module parses its arguments and calls the library.

`python -m hotu_drake.<name>` runs `commands.<name>` for `train`,
`simulate`, `demo` and `evaluate` (the method's tables, `commands.tables`);
`models`, `retarget` and `bench` run their packages' own `__main__`.
"""
