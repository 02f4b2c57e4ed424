"""Random seeds: one range for a script's ``@seed``, ``--seed`` and the Python API.

0 .. 2**31 - 1: every engine's random generator accepts it, and it prints the same in
JSON and in every language an engine might be driven from.
"""

SEED_MAX = 2**31 - 1
