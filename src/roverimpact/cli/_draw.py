"""``roverimpact draw SCENARIO.toml -o FILE.png``: picture of a scenario, to check it by eye."""

from __future__ import annotations

from pathlib import Path

import typer

from ._app import app, check_output, print_paths

#: Image types of ``draw -o`` (and of the other commands' figure options).
IMAGE_TYPES = (".png", ".svg", ".pdf")


@app.command("draw")
def draw_cmd(
    file: Path = typer.Argument(..., help="Scenario TOML file."),
    output: Path = typer.Option(Path("scenario.png"), "-o", "--output",
                                help="Output image (.png, .svg, .pdf)."),
) -> None:
    """Draw the model, the obstacle face, the contact point and the impact normal."""
    from ..report.draw import draw_setup
    from ..scenario import ImpactSetup, load_scenario

    check_output(output, folder=False, suffixes=IMAGE_TYPES)
    setup = ImpactSetup.from_scenario(load_scenario(file))
    draw_setup(setup, output)
    print_paths("wrote", output)
