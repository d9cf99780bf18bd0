"""Exceptions of the runner (standard library only, so the CLI can fail fast)."""


class StudyError(ValueError):
    """A study file or command line that cannot be run; the message is one line."""


#: studies with more cases than this need --yes
LARGE_STUDY = 10_000
