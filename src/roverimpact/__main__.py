"""``python -m roverimpact ...``: the ``roverimpact`` command (:func:`roverimpact.cli.run`)."""

if __name__ == "__main__":
    from .cli import run

    run()
