"""OMPL's C++ planners on nhsim's problems: a small harness (``harness.cpp``) compiled at bench time
against the system's OMPL (:mod:`.build`), fed the problem and FastChecker's grid (:mod:`.problem`)."""
