"""The one piece of packaging pyproject.toml cannot say: the top-level ``resources/`` folder
(shaders, font, sample motions, the browser player) goes into the wheel as ``morf/_resources/``,
where :mod:`morf.resources` finds it once installed. Every folder under it is listed as a data
package, so a folder added later ships without a change here."""

from pathlib import Path

from setuptools import find_namespace_packages, setup

SHIPPED = Path("resources")
folders = [p for p in (SHIPPED, *sorted(SHIPPED.rglob("*"))) if p.is_dir() and p.name != "__pycache__"]
data_packages = ["morf._resources" + "".join("." + part for part in p.relative_to(SHIPPED).parts) for p in folders]

setup(
    packages=find_namespace_packages(include=["morf", "morf.*", "studio", "studio.*"], exclude=["*__pycache__"])
    + data_packages,  # morf.train has no __init__.py: a namespace package
    package_dir={"morf._resources": "resources"},
    package_data={"morf.machine": ["cpuid_mask.c"], **{name: ["*"] for name in data_packages}},
)
