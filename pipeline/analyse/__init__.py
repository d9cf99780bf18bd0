"""After the combine: sensitivity indices (SALib), a polynomial-chaos surrogate (OpenTURNS) and
its emulator. Imports only the stages before it (common, study, store)."""
