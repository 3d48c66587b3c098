"""The hand-written types against openapi/openapi.yaml: every problem `type` has its exception
class (and no class claims a type the contract does not list), and every model's fields are its
schema's properties, with defaults exactly where the schema does not require them."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import pytest
import yaml

from asi_gateway import PROBLEM_CLASSES, Problem, models
from asi_gateway.problems import problem_from_body

OPENAPI = Path(__file__).resolve().parents[3] / "openapi" / "openapi.yaml"


@pytest.fixture(scope="module")
def openapi() -> dict[str, Any]:
    document: dict[str, Any] = yaml.safe_load(OPENAPI.read_text())
    return document


def problem_types(openapi: dict[str, Any]) -> set[str]:
    return set(openapi["components"]["schemas"]["Problem"]["properties"]["type"]["enum"])


def test_every_problem_type_has_an_exception_class(openapi: dict[str, Any]) -> None:
    listed = problem_types(openapi)
    assert len(listed) > 20
    missing = sorted(listed - set(PROBLEM_CLASSES))
    assert not missing, f"problem types in openapi.yaml without an exception class: {missing}"


def test_no_exception_class_for_a_type_the_contract_lacks(openapi: dict[str, Any]) -> None:
    extra = sorted(set(PROBLEM_CLASSES) - problem_types(openapi))
    assert not extra, f"exception classes for types openapi.yaml does not list: {extra}"


def test_each_class_is_raised_for_its_type_with_every_field(openapi: dict[str, Any]) -> None:
    for problem_type in problem_types(openapi):
        body = {
            "type": problem_type,
            "title": "T",
            "status": 409,
            "detail": "D",
            "instance": "/api/v1/x",
            "request_id": "r-1",
            "field": "axes.Q",
            "controller_code": -4,
        }
        error = problem_from_body(body)
        assert type(error) is PROBLEM_CLASSES[problem_type]
        assert (error.type, error.title, error.status, error.detail) == (problem_type, "T", 409, "D")
        assert (error.instance, error.request_id, error.field) == ("/api/v1/x", "r-1", "axes.Q")
        assert error.extensions == {"field": "axes.Q", "controller_code": -4}


def test_an_unknown_type_still_raises_problem_with_its_fields() -> None:
    error = problem_from_body({"type": "https://asi-gateway.dev/problems/new-kind", "title": "New", "status": 418})
    assert type(error) is Problem
    assert error.kind == "new-kind" and error.status == 418


# ---- models ----------------------------------------------------------------------------------


def resolve(openapi: dict[str, Any], node: dict[str, Any]) -> dict[str, Any]:
    """A schema with its local $ref followed, allOf merged, and a nullable oneOf's object taken."""
    while "$ref" in node:
        path = node["$ref"].removeprefix("#/").split("/")
        target: Any = openapi
        for part in path:
            target = target[part]
        node = {**target, **{k: v for k, v in node.items() if k != "$ref"}}
    if "allOf" in node:
        merged: dict[str, Any] = {"properties": {}, "required": []}
        for part in [*node["allOf"], {k: v for k, v in node.items() if k != "allOf"}]:
            part = resolve(openapi, part)
            merged["properties"].update(part.get("properties", {}))
            merged["required"] += part.get("required", [])
        return merged
    if "oneOf" in node and "properties" not in node:
        objects = [resolve(openapi, n) for n in node["oneOf"] if n.get("type") != "null"]
        if len(objects) == 1:
            return objects[0]
    return node


def schema_for(openapi: dict[str, Any], name: str) -> dict[str, Any]:
    """ "Job", or a nested one: "ControllerState.identity", "ControllerState.axes[]"."""
    first, *rest = name.split(".")
    node = resolve(openapi, openapi["components"]["schemas"][first])
    for part in rest:
        items = part.endswith("[]")
        node = resolve(openapi, node["properties"][part.removesuffix("[]")])
        if items:
            node = resolve(openapi, node["items"])
    return node


MODELS = [
    cls
    for cls in vars(models).values()
    if isinstance(cls, type) and dataclasses.is_dataclass(cls) and hasattr(cls, "SCHEMA")
]


def test_models_are_listed() -> None:
    assert {c.__name__ for c in MODELS} >= {"ControllerState", "Job", "JobProgress", "LeaseGrant", "MoveResult"}


@pytest.mark.parametrize("model", MODELS, ids=lambda c: c.__name__)
def test_model_fields_match_the_schema(openapi: dict[str, Any], model: type) -> None:
    schema = schema_for(openapi, model.SCHEMA)  # type: ignore[attr-defined]
    client_only = {"raw", *getattr(model, "CLIENT_FIELDS", ())}
    fields = {f.name: f for f in dataclasses.fields(model) if f.name not in client_only}
    assert set(fields) == set(schema["properties"]), f"{model.__name__} vs {model.SCHEMA}"  # type: ignore[attr-defined]
    without_default = {
        name
        for name, f in fields.items()
        if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING
    }
    assert without_default == set(schema.get("required", [])), f"{model.__name__}: required fields"
