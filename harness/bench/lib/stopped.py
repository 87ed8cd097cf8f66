"""A run an FMU stopped with an error status, as the error-bound benches record it (the FMU's own reason)."""


class RunStopped(RuntimeError):
    """An FMU returned an error status during a run (the FMU's own message)."""


def reason(messages, exc):
    """The FMU's first logged error text (``messages``: the driver's (status, category, text) list), else ``exc``'s."""
    errors = [text for status, _, text in messages if status >= 3]
    return errors[0] if errors else str(exc)
