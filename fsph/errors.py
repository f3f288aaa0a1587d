"""Exceptions that carry a message meant for the user, not a traceback."""


class FsphError(Exception):
    """Base class of every error fsph reports to the user."""


def _one_line(text):
    """Text with control characters (newlines included) escaped, so a
    message built from arbitrary deck content stays on one line."""
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in str(text))


class InputError(FsphError):
    """Bad input other than a deck's content: the command line, the output
    folder (a file, not writable, in use by another run). Exit 2, like a
    DeckError; the message names what and where on one line."""

    def __init__(self, message):
        super().__init__(_one_line(message))


class DeckError(InputError):
    """An input deck is unreadable or holds a value fsph cannot accept.

    The message names the file, the namelist group, the key and what was
    expected, on one line.
    """

    def __init__(self, path, group, key, expected, got=None):
        self.path = str(path)
        self.group = group
        self.key = key
        self.expected = expected
        self.got = got
        msg = f"{self._where()}: expected {expected}"
        if got is not None:
            msg += f", got {got!r}"
        super().__init__(msg)

    def _where(self):
        """The file, the group and the key, as the message names them."""
        where = self.path
        if self.group:
            where += f": &{self.group}"
        if self.key:
            where += f" key '{self.key}'"
        return where


class CheckpointError(DeckError):
    """A checkpoint is unreadable, incomplete or holds what a restart
    cannot take. Exit 2, like a deck; the message names the file, the
    dataset or attribute (`item`, e.g. "dataset /state/elements/conn") and
    what was expected, on one line."""

    def __init__(self, path, item, expected, got=None):
        self.item = item
        super().__init__(path, None, None, expected, got)

    def _where(self):
        return f"{self.path}: {self.item}" if self.item else self.path


class OutputError(FsphError):
    """Writing a run's outputs failed or would fail: the disk (or the file
    size limit) is full, the folder went away. The run stops as failed
    (exit 3); what was written before stays readable."""

    def __init__(self, message):
        super().__init__(_one_line(message))


class SimulationError(FsphError):
    """A run went bad (tangled mesh, NaN, collapsing time step...).

    Attributes name what failed, which element or node, where and when:
    location is the (r, z) [m] of the element or particle at fault (a node:
    where it started), None when that position is unknown (not finite, or
    far outside the bodies).
    """

    def __init__(self, message, *, code, index=0, time=0.0, cycle=0, location=None):
        self.code = code
        self.index = index
        self.time = time
        self.cycle = cycle
        self.location = location
        super().__init__(message)
