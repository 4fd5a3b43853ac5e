"""Trial generators the tests share with the benchmarks (``benchmarks/`` imports them from here).

Nothing here is collected as a test, and nothing here imports from ``benchmarks/``.
"""
