# Deliberately no tests: python.empty_run_fails runs pytest on this file and
# expects exit status 5 (nothing collected), the status that makes any python.*
# suite fail in ctest should it stop collecting tests.
