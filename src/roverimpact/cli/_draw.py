"""``roverimpact draw SCENARIO.toml -o FILE.png``: picture of a scenario, to check it by eye."""

from __future__ import annotations

from pathlib import Path

import typer

from ..scenario import load_scenario
from ._app import app, console


@app.command("draw")
def draw_cmd(
    file: Path = typer.Argument(..., help="Scenario TOML file."),
    output: Path = typer.Option(Path("scenario.png"), "-o", "--output",
                                help="Output image (.png, .svg, .pdf)."),
) -> None:
    """Draw the model, the obstacle face, the contact point and the impact normal."""
    from ..report.draw import draw_setup

    setup = load_scenario(file).build()
    draw_setup(setup, output)
    console.print(f"wrote {output}")
