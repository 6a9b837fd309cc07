"""Request names that are the keys of a core registry, read when they are used.

``Annotated[str, RegistryKey(METHODS, "method")]`` is a string field valid when it is a key of the
registry at the moment a request is validated, and documented in ``/openapi.json`` as an ``enum`` of the keys at the
moment the schema is generated: an entry added to ``METHODS``, ``PATHS``, ``TIMING_LAWS`` or
``PROFILES`` reaches the API with no other edit (and a test can add a throwaway entry and see it
accepted and used). An unknown name is 422 ``validation`` at the field, naming the valid ones.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any, get_args

from pydantic import GetCoreSchemaHandler, GetJsonSchemaHandler
from pydantic.json_schema import JsonSchemaValue
from pydantic_core import PydanticCustomError, core_schema


class RegistryKey:
    """The pydantic hooks of a field whose valid values are the keys of ``registry`` (read at
    validation and at schema generation) for which ``keep`` holds; ``what`` names it in
    messages."""

    def __init__(
        self,
        registry: Mapping[str, object],
        what: str,
        keep: Callable[[str], bool] | None = None,
    ) -> None:
        self.registry, self.what, self.keep = registry, what, keep

    def names(self) -> list[str]:
        """The valid names now."""
        return [k for k in self.registry if self.keep is None or self.keep(k)]

    def check(self, value: str) -> str:
        names = self.names()
        if value not in names:
            raise PydanticCustomError(
                "enum",
                "{what} must be one of {names}",
                {"what": self.what, "names": ", ".join(names)},
            )
        return value

    def __get_pydantic_core_schema__(
        self, source: Any, handler: GetCoreSchemaHandler
    ) -> core_schema.CoreSchema:
        return core_schema.no_info_after_validator_function(self.check, handler(str))

    def __get_pydantic_json_schema__(
        self, schema: core_schema.CoreSchema, handler: GetJsonSchemaHandler
    ) -> JsonSchemaValue:
        out = handler(schema)
        out["enum"] = self.names()
        return out


def names_of(field_type: Any) -> list[str]:
    """The names a ``RegistryKey`` field type accepts now."""
    (key,) = [m for m in get_args(field_type)[1:] if isinstance(m, RegistryKey)]
    return key.names()
