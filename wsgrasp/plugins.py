"""Plugin system: one pluggy project ``wsgrasp``, one entry-point group ``wsgrasp``.

A plugin is a module implementing any of the three hooks below. Each hook receives a
``register`` callback and calls it once per thing it provides::

    from wsgrasp import hookimpl

    @hookimpl
    def wsgrasp_register_grippers(register):
        register("my_gripper", Path(__file__).parent / "my_gripper" / "gripper.yaml")

Built-in grippers, segmenters and scorers are registered through the same entry
points as third-party ones; the core never imports them by name.
"""

from __future__ import annotations

import importlib.metadata
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import lru_cache
from types import ModuleType
from typing import Any, Literal

import pluggy

from wsgrasp._names import did_you_mean
from wsgrasp.errors import PluginError

__all__ = [
    "ENTRY_POINT_GROUP",
    "KINDS",
    "FailedPlugin",
    "PluginInfo",
    "Registered",
    "Registry",
    "get_registry",
    "hookimpl",
    "hookspec",
]

PROJECT = "wsgrasp"
ENTRY_POINT_GROUP = "wsgrasp"
Kind = Literal["grippers", "segmenters", "scorers"]
KINDS: tuple[Kind, ...] = ("grippers", "segmenters", "scorers")

hookspec = pluggy.HookspecMarker(PROJECT)
hookimpl = pluggy.HookimplMarker(PROJECT)


class _Hooks:
    """Hook specifications of wsgrasp."""

    @hookspec
    def wsgrasp_register_grippers(self, register: Callable[[str, Any], None]) -> None:
        """Register grippers: ``register(name, path_to_gripper_yaml)``, or a built
        ``GripperModel``, or a ``GripperDescription``."""

    @hookspec
    def wsgrasp_register_segmenters(self, register: Callable[[str, Any], None]) -> None:
        """Register segmenters: ``register(name, segmenter_class)``. The class has an
        ``Options`` pydantic model and a ``segment(scene, options)`` method."""

    @hookspec
    def wsgrasp_register_scorers(self, register: Callable[[str, Any], None]) -> None:
        """Register candidate scorers: ``register(name, scorer_class)``. The class has
        an ``Options`` pydantic model and a vectorised ``score(batch, options)``."""


@dataclass(frozen=True)
class PluginInfo:
    """Where a plugin came from."""

    name: str
    distribution: str
    version: str


@dataclass(frozen=True)
class Registered:
    """One registered thing and the plugin that registered it."""

    name: str
    kind: Kind
    obj: Any
    plugin: PluginInfo


@dataclass(frozen=True)
class FailedPlugin:
    """A plugin that could not be loaded or whose hook raised."""

    plugin: PluginInfo
    error: str
    detail: str = ""


@dataclass
class Registry:
    """Everything registered by the loaded plugins, by kind and name."""

    plugins: list[PluginInfo] = field(default_factory=list)
    failed: list[FailedPlugin] = field(default_factory=list)
    items: dict[Kind, dict[str, Registered]] = field(
        default_factory=lambda: {k: {} for k in KINDS}
    )
    conflicts: dict[Kind, dict[str, list[Registered]]] = field(
        default_factory=lambda: {k: {} for k in KINDS}
    )
    pm: pluggy.PluginManager = field(default_factory=lambda: _new_manager())

    # -- loading -----------------------------------------------------------------
    @classmethod
    def from_entry_points(cls) -> Registry:
        """Load every plugin of the ``wsgrasp`` entry-point group.

        A plugin that fails to import, or whose hook raises, is recorded in
        ``failed`` and the others still load.
        """
        registry = cls()
        for ep in _entry_points():
            dist = ep.dist.name if ep.dist is not None else "unknown"
            version = ep.dist.version if ep.dist is not None else "unknown"
            info = PluginInfo(ep.name, dist, version)
            try:
                module = ep.load()
            except Exception as exc:  # noqa: BLE001 - reported, not raised
                registry.failed.append(
                    FailedPlugin(
                        info, f"{type(exc).__name__}: {exc}", traceback.format_exc()
                    )
                )
                continue
            registry.add_plugin(module, info)
        return registry

    def add_plugin(self, module: ModuleType | object, info: PluginInfo) -> None:
        """Register one plugin object and collect what its hooks register."""
        try:
            self.pm.register(module, name=f"{info.distribution}:{info.name}")
        except Exception as exc:  # noqa: BLE001 - pluggy validation errors
            self.failed.append(FailedPlugin(info, f"{type(exc).__name__}: {exc}"))
            return
        self.plugins.append(info)
        for kind in KINDS:
            hook = getattr(self.pm.hook, f"wsgrasp_register_{kind}")
            for impl in hook.get_hookimpls():
                if impl.plugin is not module:
                    continue
                try:
                    impl.function(register=self._register_callback(kind, info))
                except Exception as exc:  # noqa: BLE001 - reported, not raised
                    self.failed.append(
                        FailedPlugin(
                            info,
                            f"hook wsgrasp_register_{kind} raised "
                            f"{type(exc).__name__}: {exc}",
                            traceback.format_exc(),
                        )
                    )

    def remove_plugin(self, info: PluginInfo) -> None:
        """Forget a plugin and everything it registered (used by tests)."""
        self.plugins = [p for p in self.plugins if p != info]
        for kind in KINDS:
            self.items[kind] = {
                n: r for n, r in self.items[kind].items() if r.plugin != info
            }
        plugin = self.pm.get_plugin(f"{info.distribution}:{info.name}")
        if plugin is not None:
            self.pm.unregister(plugin)

    def _register_callback(self, kind: Kind, info: PluginInfo) -> Callable[..., None]:
        def register(name: str, obj: Any) -> None:
            if not isinstance(name, str) or not name:
                raise PluginError(
                    f"plugin {info.name!r} ({info.distribution}) registered a "
                    f"{kind[:-1]} without a name",
                    hint="call register(name, obj) with a non-empty string name",
                )
            entry = Registered(name, kind, obj, info)
            existing = self.items[kind].get(name)
            if existing is not None or name in self.conflicts[kind]:
                clash = self.conflicts[kind].setdefault(name, [])
                if existing is not None:
                    clash.append(existing)
                    del self.items[kind][name]
                clash.append(entry)
                return
            self.items[kind][name] = entry

        return register

    # -- look-up -----------------------------------------------------------------
    def names(self, kind: Kind) -> list[str]:
        """Sorted names registered for ``kind``."""
        return sorted(self.items[kind])

    def get(self, kind: Kind, name: str) -> Registered:
        """Look up a registered thing; unknown or duplicated names raise
        ``PluginError`` with the closest names or both distributions."""
        if name in self.conflicts[kind]:
            dists = ", ".join(
                f"{r.plugin.distribution} {r.plugin.version} (plugin {r.plugin.name})"
                for r in self.conflicts[kind][name]
            )
            raise PluginError(
                f"{kind[:-1]} {name!r} is registered by more than one plugin: {dists}",
                hint="uninstall one of these distributions or rename the "
                f"{kind[:-1]} in one of them",
            )
        try:
            return self.items[kind][name]
        except KeyError:
            raise PluginError(
                f"unknown {kind[:-1]} {name!r}{did_you_mean(name, self.names(kind))}",
                hint=f"run `wsgrasp plugins` to list the {kind} that are installed",
            ) from None

    def plugin_summary(self) -> list[dict[str, Any]]:
        """Per plugin: distribution, version and what it registers, as plain data."""
        out = []
        for info in self.plugins:
            provided: dict[str, list[str]] = {}
            for kind in KINDS:
                names = [n for n, r in self.items[kind].items() if r.plugin == info]
                names += [
                    n
                    for n, rs in self.conflicts[kind].items()
                    if any(r.plugin == info for r in rs)
                ]
                if names:
                    provided[kind] = sorted(names)
            out.append(
                {
                    "name": info.name,
                    "distribution": info.distribution,
                    "version": info.version,
                    "provides": provided,
                }
            )
        return out


def _new_manager() -> pluggy.PluginManager:
    pm = pluggy.PluginManager(PROJECT)
    pm.add_hookspecs(_Hooks)
    return pm


def _entry_points() -> list[importlib.metadata.EntryPoint]:
    eps = importlib.metadata.entry_points(group=ENTRY_POINT_GROUP)
    # One entry point per (distribution, name): editable installs can show twice.
    seen: set[tuple[str, str]] = set()
    unique = []
    for ep in sorted(eps, key=lambda e: (e.dist.name if e.dist else "", e.name)):
        key = (ep.dist.name if ep.dist else "", ep.name)
        if key not in seen:
            seen.add(key)
            unique.append(ep)
    return unique


@lru_cache(maxsize=1)
def get_registry() -> Registry:
    """The process-wide registry, loaded from entry points on first use."""
    return Registry.from_entry_points()
