"""docs/configuration.md is generated from the schema and must not drift from it."""

import re
from pathlib import Path
from typing import Annotated, Literal

from pydantic import BaseModel, Discriminator, Field

from dpcollapse import config_doc
from tests.helpers import ROOT

DOC = ROOT / "docs" / "configuration.md"
REGENERATE = "run `python -m dpcollapse.config_doc` and commit docs/configuration.md"


def _rows(text: str) -> dict[str, list[str]]:
    """Table rows by key: ``| `a.b` | default | unit | allowed | meaning |``."""
    rows = {}
    for line in text.splitlines():
        if line.startswith("| `"):
            cells = [c.strip() for c in re.split(r"(?<!\\)\|", line.strip())[1:-1]]
            rows[cells[0].strip("`")] = cells
    return rows


def test_configuration_md_matches_the_schema():
    assert DOC.read_text(encoding="utf-8") == config_doc.render(), REGENERATE


def test_a_known_key_appears_with_its_unit_and_default():
    # the density of the material, wherever a restructured schema puts it
    rows = _rows(DOC.read_text(encoding="utf-8"))
    density = [cells for key, cells in rows.items() if key.endswith(".density")]
    assert density, "no *.density key in docs/configuration.md"
    _key, default, unit, allowed, meaning = density[0]
    assert (default, unit, allowed) == ("1550.0", "kg/m^3", "number > 0"), density[0]
    assert "density" in meaning.lower() and "[" not in meaning  # the unit is in its own column


def test_check_mode_exit_codes(tmp_path):
    out = tmp_path / "configuration.md"
    assert config_doc.main(["--check", "--out", str(out)]) == 1  # missing
    assert config_doc.main(["--out", str(out)]) == 0
    assert config_doc.main(["--check", "--out", str(out)]) == 0
    out.write_text(out.read_text(encoding="utf-8").replace("1550.0", "1500.0"), encoding="utf-8")
    assert config_doc.main(["--check", "--out", str(out)]) == 1


def test_default_path_is_the_checked_in_file():
    assert Path(config_doc.DOC_PATH) == DOC


# --------------------------------------------------------------- generic over the model tree
class _Grain(BaseModel):
    """Grains."""

    diameter: float = Field(7e-4, gt=0, description="Grain diameter d [m]",
                            json_schema_extra={"unit": "m"})


class _Trapezoid(BaseModel):
    """A trapezoid against a wall."""

    kind: Literal["trapezoid"] = "trapezoid"
    height: float = Field(0.25, gt=0, le=1)


class _Layer(BaseModel):
    kind: Literal["layer"] = "layer"
    thickness: Annotated[float, Field(gt=0)] | None = None
    grain: _Grain = Field(default_factory=_Grain)
    regions: list[_Grain] = Field(default_factory=list)


class _DruckerPrager(BaseModel):
    law: Literal["drucker_prager"] = "drucker_prager"


class _MuI(BaseModel):
    law: Literal["mu_i"] = "mu_i"
    grain: _Grain | None = None


class _Root(BaseModel):
    scene: _Trapezoid | _Layer = Field(default_factory=_Layer, discriminator="kind",
                                       description="The scene")
    model: Annotated[_DruckerPrager | _MuI, Discriminator("law")] = _DruckerPrager()
    verbose: bool = False


def test_nested_models_and_discriminated_unions():
    text = "\n".join(config_doc.render_model(_Root))
    rows = _rows(text)
    assert rows["scene.height"][1:4] == ["0.25", "—", "number > 0, ≤ 1"]
    assert rows["scene.thickness"][3] == "number > 0, or null"
    assert rows["scene.grain.diameter"][1:3] == ["0.0007", "m"]
    assert rows["scene.grain.diameter"][4] == "Grain diameter d"
    assert "scene.regions[].diameter" in rows and "model.grain.diameter" in rows
    assert rows["verbose"][1:4] == ["false", "—", "true / false"]
    for heading in ("`scene` with `kind: trapezoid`", "`scene` with `kind: layer`",
                    "`model` with `law: drucker_prager`", "`model` with `law: mu_i`"):
        assert heading in text, heading
    assert "chosen by `scene.kind`; default: `kind: layer`" in text
    assert "chosen by `model.law`; default: `law: drucker_prager`" in text
    assert "A trapezoid against a wall." in text
