# SPDX-License-Identifier: BSD-2-Clause
"""Records and their owners (docs/design.md, "Records and their owners"),
where the compiler cannot check it.

The records of state (app_ctx's model, asm, newton, start, step, energy,
progress, error; the run driver's restart record) have private components
in the module that writes them: the compiler refuses a write anywhere else.
The test checks that they stay so (test_state_records_are_private).

The value records stay public, read in hot loops or passed between modules:
the configuration (nuno_config and its groups) and the lattice (lattice_t).
They are written only while they are built. A pure scan of src/ (no build,
no run) checks what the compiler cannot, listing each offending statement
with its file and line:

- nothing writes through app_ctx's cfg, a pointer to the caller's
  configuration (main's, or identification's trial one): no assignment,
  allocation or alias of <app>%cfg%... anywhere, no assignment to <app>%cfg
  as a whole (pointing it, =>, is allowed);
- nothing writes <app>%lat%... outside module lattice, its builder;
- a dummy argument of type nuno_config or lattice_t is intent(in) outside
  the modules that build one (the input, identification's trial
  configuration; the lattice).

What it cannot see: a field passed as an actual argument to a procedure of
another file that writes it (the procedure's intent is there; its dummy
is caught by the third rule when it is the whole record)."""
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
SRC = ROOT / "src"

# The value records' types -> the modules that build them: only there may
# a procedure take one as a dummy argument it can write.
BUILDERS = {
    "nuno_config": {"config", "input", "input_namelist", "input_checks", "identify_params"},
    "lattice_t": {"lattice"},
}
# The components of app_ctx that hold a value record, and the modules that
# may write through them: the configuration (a pointer) in none, the
# lattice in its own module.
VALUE_COMPONENTS = {"cfg": set(), "lat": {"lattice"}}
# The records of state with private components: type -> the module that
# defines and alone writes it.
PRIVATE_RECORDS = {
    "model_state_t": "model_state",
    "assembly_t": "model_state",
    "newton_state_t": "newton_state",
    "newton_start_t": "newton_start",
    "step_settings_t": "step_settings",
    "energy_integrals_t": "energy_integrals",
    "progress_t": "run_progress",
    "run_error_t": "run_error",
    "restart_state_t": "run_checkpoint",
    "reduced_t": "reduced",
    "elements_t": "reduced",
    "inner_pc_t": "reduced",
    "s_store_t": "reduced_storage",
    "aij_view_t": "reduced_storage",
    "mg_glue_t": "reduced_mg",
    "guess_t": "reduced_guess",
    "contact_model_t": "contact_model",
    "obstacle_set_t": "obstacle_set",
    "contact_lag_t": "contact_nodes",
    "contact_record_t": "contact_record",
    "pm_list_t": "process_models",
    "pair_blocks_t": "pair_blocks",
    "constraint_set_t": "constraints",
    "node_blocks_t": "node_blocks",
    "series_state": "output",
    "safe_state": "output",
    "checkpoint_state": "output",
    "obstacles_state": "output",
    "ident_params_t": "identify_params",
    "ident_obs_t": "identify_objective",
    "ident_run_t": "identify_adjoint",
    "ident_core_t": "identify_adjoint",
    "ident_t": "identify",
}


def strip_comment(line):
    """The line without its ! comment and with string literals blanked."""
    out, quote = [], None
    for ch in line:
        if quote:
            out.append(" ")
            if ch == quote:
                quote = None
        elif ch in "'\"":
            quote = ch
            out.append(" ")
        elif ch == "!":
            break
        else:
            out.append(ch)
    return "".join(out)


def statements(text):
    """(first line number, statement) of a free-form source: continuation
    lines joined, comments dropped, ';' splitting statements."""
    joined, start, pending = [], None, ""
    for n, raw in enumerate(text.splitlines(), 1):
        if raw.lstrip().startswith("#"):          # preprocessor line
            continue
        line = strip_comment(raw).rstrip()
        if not pending:
            start = n
        body = line.lstrip()
        if pending and body.startswith("&"):
            body = body[1:]
        if body.endswith("&"):
            pending += body[:-1] + " "
            continue
        pending += body
        for part in pending.split(";"):
            if part.strip():
                joined.append((start, part.strip()))
        pending = ""
    return joined


def split_top(s, seps):
    """Positions in s of the characters in seps at parenthesis depth 0."""
    depth, pos = 0, []
    for i, ch in enumerate(s):
        if ch == "(":
            depth += 1
        elif ch == ")":
            depth -= 1
        elif depth == 0 and ch in seps:
            pos.append(i)
    return pos


def skip_parens(s, i):
    """Index after the balanced parenthesis group that starts at s[i]."""
    depth = 0
    for j in range(i, len(s)):
        if s[j] == "(":
            depth += 1
        elif s[j] == ")":
            depth -= 1
            if depth == 0:
                return j + 1
    return len(s)


def written(stmt):
    """The variables a statement writes, each with how: '=' (the left side
    of an assignment, also after a one-line if or where), '=>' (a pointer
    assignment), 'alloc' (allocate, deallocate, nullify), 'alias' (an
    associate name, which can be written through)."""
    s = stmt
    m = re.match(r"(?i)(else\s+)?(if|where)\s*\(", s)
    while m:
        s = s[skip_parens(s, m.end() - 1):].strip()
        if re.fullmatch(r"(?i)then", s):
            return []
        m = re.match(r"(?i)(if|where)\s*\(", s)
    if re.match(r"(?i)associate\s*\(", s):
        return [(d, "alias") for d in re.findall(r"=>\s*([\w%]+(?:\([^()]*\))?(?:%\w+)*)", s)]
    m = re.match(r"(?i)(allocate|deallocate|nullify)\s*\(", s)
    if m:
        inner = s[m.end():skip_parens(s, m.end() - 1) - 1]
        cuts = [-1] + split_top(inner, ",") + [len(inner)]
        items = [inner[a + 1:b].strip() for a, b in zip(cuts, cuts[1:])]
        return [(x, "alloc") for x in items if not re.match(r"(?i)(stat|errmsg|source|mold)\s*=", x)]
    if re.match(r"(?i)(do|forall)\b", s) or "::" in s:
        return []
    for i in split_top(s, "="):
        before = s[i - 1] if i > 0 else ""
        after = s[i + 1] if i + 1 < len(s) else ""
        if before in "=/<>" or after == "=":
            continue
        return [(s[:i].strip(), "=>" if after == ">" else "=")]
    return []


def components(designator):
    """The component names of a designator, subscripts dropped:
    'ctx%lat%mass(i, j)' -> ['ctx', 'lat', 'mass']."""
    depth, flat = 0, []
    for ch in designator:
        if ch == "(":
            depth += 1
        elif ch == ")":
            depth -= 1
        elif depth == 0:
            flat.append(ch)
    return [part.strip().lower() for part in "".join(flat).split("%")]


def app_names(texts):
    """The names declared type(app_ctx) anywhere (variables, dummies,
    components, pointers: ctx, app)."""
    names = set()
    for text in texts:
        for _, stmt in statements(text):
            m = re.match(r"(?i)type\s*\(\s*app_ctx\s*\).*::(.*)", stmt)
            if m:
                for item in m.group(1).split(","):
                    names.add(re.match(r"\s*(\w*)", item).group(1).lower())
    return names - {""}


def value_write(comps, how, apps):
    """The value component of an app_ctx a write reaches, or None:
    ctx%cfg%time%dt = ... reaches cfg; ctx%cfg => c points it (allowed);
    ctx%cfg = c writes the configuration it points to."""
    for i in range(1, len(comps)):
        if comps[i - 1] in apps and comps[i] in VALUE_COMPONENTS:
            if len(comps) == i + 1 and how == "=>":
                return None
            return comps[i]
    return None


def module_of(text):
    """The module a source file belongs to (a submodule: its ancestor; the
    main program: its name)."""
    m = re.search(r"(?im)^\s*submodule\s*\(\s*(\w+)", text)
    if m:
        return m.group(1).lower()
    m = re.search(r"(?im)^\s*module\s+(?!procedure\b|subroutine\b|function\b)(\w+)", text)
    if m:
        return m.group(1).lower()
    m = re.search(r"(?im)^\s*program\s+(\w+)", text)
    return m.group(1).lower() if m else None


# a procedure's first statement: any prefix (pure, module, a result type
# with its kind, PetscInt) before subroutine or function and its name
PROCEDURE = re.compile(r"(?i)^(?:\w+(?:\s*\([^)]*\))?\s+)*(subroutine|function)\s+(\w+)\s*(?:\(([^)]*)\))?")
END_PROCEDURE = re.compile(r"(?i)^end\s*(subroutine|function)\b")


def violations_in(text, name, apps):
    """Each statement of the file that writes a value record after it is
    built (apps: the names of app_ctx variables and components)."""
    module = module_of(text)
    found = []
    dummies = []                                 # a stack: contained procedures
    for line, stmt in statements(text):
        m = PROCEDURE.match(stmt)
        if m and not re.match(r"(?i)end\b", stmt):
            dummies.append({a.strip().lower() for a in (m.group(3) or "").split(",") if a.strip()})
            continue
        if END_PROCEDURE.match(stmt) and dummies:
            dummies.pop()
            continue
        for d, how in written(stmt):
            comp = value_write(components(d), how, apps)
            if comp is not None and module not in VALUE_COMPONENTS[comp]:
                found.append(f"{name}:{line}: {stmt}   [{comp} is written only where it is built]")
        m = re.match(r"(?i)type\s*\(\s*(\w+)\s*\)(.*)::(.*)", stmt)
        if m and m.group(1).lower() in BUILDERS and dummies and module not in BUILDERS[m.group(1).lower()]:
            attrs = m.group(2).lower().replace(" ", "")
            names = {re.match(r"\s*(\w*)", item).group(1).lower() for item in m.group(3).split(",")}
            if names & dummies[-1] and "intent(in)" not in attrs:
                found.append(f"{name}:{line}: {stmt}   [a writable {m.group(1)}: built only in "
                             f"{', '.join(sorted(BUILDERS[m.group(1).lower()]))}]")
    return found


def source_files():
    return sorted(p for p in SRC.rglob("*") if p.suffix.lower() in (".f90",))


def test_value_records_are_written_only_where_built():
    files = source_files()
    assert any(p.name == "app_context.F90" for p in files)
    texts = {p: p.read_text() for p in files}
    apps = app_names(texts.values())
    assert {"ctx", "app"} <= apps
    found = []
    for p in files:
        found += violations_in(texts[p], str(p.relative_to(ROOT)), apps)
    assert not found, "value records written outside where they are built:\n" + "\n".join(found)


def test_state_records_are_private():
    """Each record of state is defined in its module with private
    components (the compiler's rule then), and the builders named above
    are real modules (a renamed one would make the scan pass vacuously)."""
    texts = {p: p.read_text() for p in source_files()}
    modules = {module_of(t) for t in texts.values()}
    for builders in BUILDERS.values():
        assert builders <= modules, builders - modules
    for record, owner in PRIVATE_RECORDS.items():
        where = [t for t in texts.values()
                 if re.search(r"(?im)^\s*type\s*(,[^:]*)?::\s*" + record + r"\s*$", t)]
        assert len(where) == 1, record
        assert module_of(where[0]) == owner, (record, owner)
        body = re.search(r"(?ims)^\s*type\s*(?:,[^:]*)?::\s*" + record + r"\s*$(.*?)^\s*end\s*type", where[0]).group(1)
        first = next(s for _, s in statements(body))
        assert first.lower() == "private", f"{record}: its components are to be private"
    ctx = (SRC / "solver" / "app_context.F90").read_text().lower()
    body = ctx[ctx.index("type :: app_ctx"):ctx.index("end type app_ctx")]
    for comp in VALUE_COMPONENTS:
        assert re.search(r"::\s*" + comp + r"\b", body), comp


def test_the_scan_finds_writes():
    """The scanner itself: each form of write outside where a value record
    is built is found; reads, pointing the configuration and the builders'
    own writes are not."""
    text = """module timestepping
contains
  subroutine s(ctx, cfg, lat, c2)
    type(app_ctx), intent(inout) :: ctx
    type(nuno_config), intent(inout) :: cfg
    type(lattice_t) :: lat
    type(nuno_config), intent(in) :: c2
    type(lattice_t) :: local_copy
    ctx%cfg%time%dt = 0.0_rp
    if (ctx%step%fixed_step) h = ctx%cfg%time%dt
    if (x > 0) ctx%cfg%scene%keyframe_dx(i, &
      j) = 1.0_rp
    allocate(ctx%lat%mass(3, n))
    ctx%cfg => c2
    ctx%cfg = c2
    call f(ctx%cfg%time%dt == t, a=ctx%lat%nx)
    id%app%lat%e_s = 1; ctx%lat%nodal%n = 0
    x = merge(ctx%cfg%time%dt, 0.0_rp, ctx%use_reduced)
    local_copy%e_s = 0; cfg%time%dt = 0
    b = ctx%lat%nx /= 0 ! ctx%lat%nx = 1
    associate (m => ctx%cfg%material)
    end associate
  end subroutine s
  type :: r_t
    type(lattice_t), pointer :: lat
  end type r_t
end module timestepping
"""

    def lines(found):
        return sorted(int(f.split(":")[1]) for f in found)

    apps = app_names([text]) | {"app"}
    assert apps == {"ctx", "app"}
    assert lines(violations_in(text, "t.F90", apps)) == [5, 6, 9, 11, 13, 15, 17, 17, 21]
    # in the lattice's own module its writes and its writable dummies are
    # its own, the configuration's are not
    owner = text.replace("module timestepping", "module lattice").replace("end module lattice", "end module")
    assert lines(violations_in(owner, "t.F90", apps)) == [5, 9, 11, 15, 21]
