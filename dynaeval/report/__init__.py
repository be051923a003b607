"""Results documents (leaderboard JSON), tables and reports."""

from dynaeval.report.results import (
    SCHEMA,
    RunRecord,
    build_results,
    load_results,
    schema_path,
    strict,
    write_json_atomic,
)
from dynaeval.report.table import summary_table

__all__ = [
    "SCHEMA",
    "RunRecord",
    "build_results",
    "load_results",
    "schema_path",
    "strict",
    "summary_table",
    "write_json_atomic",
]
