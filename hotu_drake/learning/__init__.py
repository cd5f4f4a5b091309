"""Learning in PyTorch (pydrake-free): networks, checkpoints, trainers.

Nothing under this package imports pydrake; it sees the world through the
gymnasium API and plain arrays.
"""
