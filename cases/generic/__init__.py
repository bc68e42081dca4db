"""Generic cases described by a case file: a DE part (built-in packings or a user's YADE
script), an FE mesh, a DE zone and the coupling (docs/case-files.md)."""
from cases.generic.model import CaseModel, run
from cases.generic.schema import GENERIC as SCHEMA, check
