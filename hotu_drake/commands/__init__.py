"""The command lines: each module parses its arguments and calls the library.

`python -m hotu_drake.<name>` runs `commands.<name>` for `train`,
`simulate`, `demo`, `retarget` (its package's `__main__` hands over: its
`--physics` composes a diagram, above the retargeting itself) and
`evaluate` (the method's tables, `commands.tables`); `models` and `bench`
run their packages' own `__main__`.
"""
