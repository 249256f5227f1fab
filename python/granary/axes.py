"""The short names of sweep axes, as the report, the export and `--only` name them: the
thesis' symbol of an axis ("W" for /silo/base_outlets/0/width, "D_b", "X_db", "mu"), or its
short path ("base_outlets.0.width") where two axes share a symbol or it has none. Mirrors
analysis::axis_names (src/analysis/system.cpp) and axis_short_names (src/analysis/axes.cpp);
python/tests/test_analyses.py checks the names against the export's columns."""


def short_axis(pointer):
    """The short path of an axis: /silo/base_outlets/0/width -> base_outlets.0.width."""
    s = pointer[1:] if pointer.startswith("/") else pointer
    for prefix in ("silo/", "bodies/", "contact/", "discharge/", "output/", "bed/"):
        if s.startswith(prefix):
            s = s[len(prefix):]
    return s.replace("/", ".")


def _at(spec, *keys):
    for k in keys:
        spec = spec.get(k, {}) if isinstance(spec, dict) else {}
    return spec


def _count(spec, group, items):
    v = _at(spec, group).get(items) if isinstance(_at(spec, group), dict) else None
    return len(v) if isinstance(v, list) else 0


def _fraction_symbol(spec, k):
    species = _at(spec, "bodies").get("species") if isinstance(_at(spec, "bodies"), dict) else None
    entry = species[k] if isinstance(species, list) and k < len(species) and isinstance(species[k], dict) else {}
    shape = entry.get("shape", "")
    if shape in ("dumbbell", "disc", "snowman"):
        return {"dumbbell": "X_db", "disc": "X_d", "snowman": "X_sm"}[shape]
    return "X_" + (entry["name"] if "name" in entry else str(k))


def axis_symbol(pointer, spec):
    """The symbol of one axis (the pointer itself when it has none)."""
    if pointer in ("engine", "/engine"):
        return "engine"
    p = pointer.split("/")[1:]

    def is_(*want):
        return len(p) == len(want) and all(p[i].isdigit() if w == "#" else p[i] == w for i, w in enumerate(want))

    if is_("silo", "base_outlets", "#", "width"):
        return f"W_{int(p[2]) + 1}" if _count(spec, "silo", "base_outlets") > 1 else "W"
    if is_("silo", "base_outlets", "#", "center"):
        return f"x_{int(p[2]) + 1}"
    table = [(("silo", "side_outlets", "#", "width"), "W_s"), (("silo", "side_outlets", "#", "bottom"), "h_s"),
             (("silo", "obstacles", "#", "y"), "h"), (("silo", "obstacles", "#", "x"), "x_o"),
             (("silo", "obstacles", "#", "diameter"), "D_o"), (("silo", "width"), "L"),
             (("silo", "height"), "silo height"), (("bodies", "count"), "N"), (("bodies", "density"), "rho"),
             (("bodies", "species", "#", "shape"), "shape"), (("bodies", "species", "#", "diameter"), "d"),
             (("bodies", "species", "#", "big_diameter"), "D_b"), (("bodies", "species", "#", "n"), "n"),
             (("contact", "mu"), "mu"), (("contact", "mu_wall"), "mu_w"), (("contact", "kn"), "K_n"),
             (("contact", "kt"), "K_t"), (("contact", "gamma_n"), "gamma_n"), (("contact", "gamma_t"), "gamma_t"),
             (("time_step",), "dt"), (("gravity",), "g"), (("discharge", "mode"), "mode"),
             (("discharge", "reinject_speed"), "reinjection speed"), (("discharge", "max_time"), "t_max"),
             (("seed",), "seed")]
    if is_("bodies", "species", "#", "fraction"):
        return _fraction_symbol(spec, int(p[2]))
    for want, symbol in table:
        if is_(*want):
            return symbol
    return pointer


def axis_short_names(axes, spec):
    """{pointer: short name} of the sweep axes, given a resolved run spec of the campaign."""
    symbols = {a: axis_symbol(a, spec) for a in axes}
    uses = {}
    for s in symbols.values():
        uses[s] = uses.get(s, 0) + 1
    return {a: short_axis(a) if uses[s] > 1 or s == a else s for a, s in symbols.items()}
