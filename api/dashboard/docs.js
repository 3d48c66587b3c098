// The API docs page (docs.html): fetches the gateway's own OpenAPI document (/api/v1/openapi.yaml,
// public), parses it with js-yaml (the global `jsyaml`) and renders it as plain, printable HTML: the
// description, a table of contents, every operation by tag (parameters, request body, responses,
// examples) with $ref resolved for display, then the schemas. Built from DOM nodes and text only,
// never from HTML strings, so nothing in the document can inject markup (and the CSP holds).

import { el } from "./dom.js";

const METHODS = ["get", "put", "post", "patch", "delete", "head", "options"];
const ROLE_SUFFIX = /;\s*((?:viewer|operator|admin)(?:\s*\/\s*(?:viewer|operator|admin))?)\s*$/;
const MAX_DEPTH = 4;  // nested inline objects shown inside a property table

let doc = null;  // the parsed OpenAPI document

// ---------------------------------------------------------------------------------------------
// $ref

// "#/components/schemas/Job" -> the value it points at (JSON pointer with ~1 / ~0 escapes).
function pointer(ref) {
  if (typeof ref !== "string" || !ref.startsWith("#/")) return undefined;
  return ref.slice(2).split("/")
    .map((p) => p.replace(/~1/g, "/").replace(/~0/g, "~"))
    .reduce((node, key) => (node === undefined || node === null ? undefined : node[key]), doc);
}

// The value with its $ref chain followed; keywords next to a $ref (3.1 allows a description there)
// win over the target's.
function deref(value) {
  let v = value;
  for (let hops = 0; v && typeof v === "object" && typeof v.$ref === "string" && hops < 32; hops++) {
    const { $ref, ...beside } = v;
    const target = pointer($ref);
    if (target === undefined) return v;
    v = Object.keys(beside).length ? { ...target, ...beside } : target;
  }
  return v;
}

const schemaName = (ref) => /^#\/components\/schemas\/([^/]+)$/.exec(ref || "")?.[1];
const schemaAnchor = (name) => `schema-${name}`;
const opAnchor = (op, method, path) => `op-${op.operationId || `${method}-${path}`}`;

// ---------------------------------------------------------------------------------------------
// Prose: the Markdown the document uses (paragraphs, "- " lists, `code`, **bold**, [links](url)).

function inline(text) {
  const out = [];
  const re = /`([^`]+)`|\*\*([^*]+)\*\*|\[([^\]]+)\]\(([^)\s]+)\)/g;
  let at = 0;
  for (let m = re.exec(text); m; m = re.exec(text)) {
    if (m.index > at) out.push(text.slice(at, m.index));
    if (m[1] !== undefined) out.push(el("code", {}, m[1]));
    else if (m[2] !== undefined) out.push(el("strong", {}, m[2]));
    else out.push(safeLink(m[3], m[4]));
    at = re.lastIndex;
  }
  if (at < text.length) out.push(text.slice(at));
  return out;
}

// Only http(s) and in-page links become links: a javascript: URL in the document stays text.
function safeLink(text, href) {
  return /^(https?:|#|\/)/.test(href) ? el("a", { href }, text) : text;
}

function prose(text, className = "prose") {
  const box = el("div", { class: className });
  if (!text) return box;
  for (const block of String(text).trim().split(/\n\s*\n/)) {
    const lines = block.split("\n");
    if (/^\s*[-*] /.test(lines[0])) {
      const list = el("ul");
      let item = null;
      for (const line of lines) {
        const m = /^\s*[-*] (.*)$/.exec(line);
        if (m) {
          item = [m[1]];
          list.append(el("li"));
        } else if (item) {
          item.push(line.trim());
        }
        if (item) list.lastChild.replaceChildren(...inline(item.join(" ")));
      }
      box.append(list);
    } else {
      box.append(el("p", {}, ...inline(lines.map((l) => l.trim()).join(" "))));
    }
  }
  return box;
}

// ---------------------------------------------------------------------------------------------
// Schemas

function joinNodes(parts, separator) {
  return parts.flatMap((p, i) => (i ? [separator, ...p] : p));
}

// A short type for a table cell: "string", "array of Job", "one of a, b", links to named schemas.
function typeNodes(schema, depth = 0) {
  if (!schema || depth > 8) return ["any"];
  const name = schemaName(schema.$ref);
  if (name) return [el("a", { href: `#${schemaAnchor(name)}`, class: "schema-link" }, name)];
  const s = deref(schema);
  if (!s || typeof s !== "object") return ["any"];
  if (s.const !== undefined) return [el("code", {}, JSON.stringify(s.const))];
  if (Array.isArray(s.enum)) return ["one of ", ...joinNodes(s.enum.map((v) => [el("code", {}, JSON.stringify(v))]), ", ")];
  for (const [key, word] of [["oneOf", " | "], ["anyOf", " | "], ["allOf", " & "]]) {
    if (Array.isArray(s[key]) && !s.properties) return joinNodes(s[key].map((x) => typeNodes(x, depth + 1)), word);
  }
  const types = Array.isArray(s.type) ? s.type : [s.type || (s.properties ? "object" : s.items ? "array" : "any")];
  return joinNodes(types.map((t) => {
    if (t === "array") return ["array of ", ...typeNodes(s.items, depth + 1)];
    if (t === "object" && !s.properties && s.additionalProperties && typeof s.additionalProperties === "object") {
      return ["map of ", ...typeNodes(s.additionalProperties, depth + 1)];
    }
    return [s.format ? `${t} (${s.format})` : t];
  }), " | ");
}

// "default 60 · 1 ≤ value ≤ 86400 · pattern ^g-…": the constraints of one schema, for people.
function constraints(s) {
  const parts = [];
  if (s.default !== undefined) parts.push(`default ${JSON.stringify(s.default)}`);
  const low = s.minimum ?? s.exclusiveMinimum;
  const high = s.maximum ?? s.exclusiveMaximum;
  if (low !== undefined || high !== undefined) {
    const lo = low === undefined ? "" : `${low} ${s.exclusiveMinimum !== undefined ? "<" : "≤"} `;
    const hi = high === undefined ? "" : ` ${s.exclusiveMaximum !== undefined ? "<" : "≤"} ${high}`;
    parts.push(`${lo}value${hi}`);
  }
  const range = (what, lo, hi) => {
    if (lo !== undefined && hi !== undefined) parts.push(`${what} ${lo}..${hi}`);
    else if (lo !== undefined) parts.push(`${what} ≥ ${lo}`);
    else if (hi !== undefined) parts.push(`${what} ≤ ${hi}`);
  };
  range("length", s.minLength, s.maxLength);
  range("items", s.minItems, s.maxItems);
  if (s.pattern) parts.push(`pattern ${s.pattern}`);
  return parts.join(" · ");
}

// The object a property holds, directly or as array items, when it is not a named schema (those are
// links): an inline one, or one reached by a $ref elsewhere (GcodeJobSpec's options are
// #/components/parameters/GcodeOptions/schema).
function inlineObject(schema) {
  if (!schema || schemaName(schema.$ref)) return null;
  const s = deref(schema);
  if (s?.properties) return s;
  if (s?.items && !schemaName(s.items.$ref) && deref(s.items)?.properties) return deref(s.items);
  return null;
}

function propertyTable(s, depth) {
  const required = new Set(s.required || []);
  const rows = Object.entries(s.properties).map(([name, raw]) => {
    const p = deref(raw) || {};
    // A named schema's own description is in the schemas section (its link); only a description
    // written next to the $ref is shown here.
    const description = schemaName(raw?.$ref) ? raw.description : p.description;
    const notes = constraints(p);
    const nested = depth < MAX_DEPTH ? inlineObject(raw) : null;
    return el("tr", {},
      el("td", { class: "prop-name" }, el("code", {}, name), required.has(name) ? el("span", { class: "required", title: "required" }, " *") : null),
      el("td", { class: "prop-type" }, ...typeNodes(raw)),
      el("td", {}, description ? prose(description, "prose small") : null,
         notes ? el("div", { class: "meta" }, notes) : null,
         nested ? schemaBody(nested, depth + 1) : null));
  });
  return el("table", { class: "props" },
    el("thead", {}, el("tr", {}, el("th", {}, "field"), el("th", {}, "type"), el("th", {}, "description"))),
    el("tbody", {}, ...rows));
}

// What a schema says, at some depth: its properties as a table, its alternatives, or its type.
function schemaBody(schema, depth = 0) {
  const s = deref(schema) || {};
  const box = el("div", { class: "schema-body" });
  if (s.properties) {
    box.append(propertyTable(s, depth));
    if (s.additionalProperties === false) box.append(el("div", { class: "meta" }, "No other fields."));
  }
  const alternatives = s.oneOf || s.anyOf;
  if (Array.isArray(alternatives)) {
    const word = s.oneOf ? "Exactly one of:" : "Any of:";
    box.append(el("div", { class: "meta" }, word), el("ul", { class: "alternatives" }, ...alternatives.map((alt) => {
      const a = deref(alt) || {};
      const shortRequired = !a.properties && Array.isArray(a.required)
        ? ["with ", ...joinNodes(a.required.map((r) => [el("code", {}, r)]), ", ")] : null;
      if (!alt.$ref && a.properties && depth < MAX_DEPTH) return el("li", {}, schemaBody(a, depth + 1));
      return el("li", {}, ...(shortRequired || typeNodes(alt)));
    })));
  }
  if (!s.properties && !alternatives) {
    const notes = constraints(s);
    box.append(el("div", {}, "Type: ", ...typeNodes(schema), notes ? el("span", { class: "meta" }, ` (${notes})`) : null));
  }
  return box;
}

// A request or response body's schema: a named schema is a link plus its fields; an inline one its fields.
function bodySchema(schema) {
  const name = schemaName(schema?.$ref);
  return el("div", { class: "body-schema" },
    name ? el("div", {}, "Schema: ", ...typeNodes(schema)) : null,
    schemaBody(schema));
}

// ---------------------------------------------------------------------------------------------
// Examples

function pretty(value) {
  return typeof value === "string" ? value : JSON.stringify(value, null, 2);
}

function exampleBlock(title, value) {
  return el("details", { class: "example" }, el("summary", {}, title), el("pre", {}, pretty(value)));
}

// The examples of a media type (or a schema's `example`), each in its own block.
function examplesOf(media) {
  const out = [];
  if (media.example !== undefined) out.push(exampleBlock("Example", media.example));
  for (const [name, raw] of Object.entries(media.examples || {})) {
    const ex = deref(raw) || {};
    out.push(exampleBlock(ex.summary ? `Example: ${ex.summary}` : `Example: ${name}`, ex.value));
  }
  const schema = deref(media.schema);
  if (!out.length && schema?.example !== undefined) out.push(exampleBlock("Example", schema.example));
  return out;
}

// ---------------------------------------------------------------------------------------------
// Operations

function roleOf(op) {
  if (Array.isArray(op.security) && op.security.length === 0) return "public";
  return ROLE_SUFFIX.exec(op.summary || "")?.[1].replace(/\s+/g, "") || null;
}

// Path-level and operation parameters (the operation's win), resolved. An object parameter of
// style form, explode (GcodeOptions) becomes one query parameter per property, as it is sent.
function parametersOf(pathItem, op) {
  const byKey = new Map();
  for (const raw of [...(pathItem.parameters || []), ...(op.parameters || [])]) {
    const p = deref(raw);
    if (p) byKey.set(`${p.in}:${p.name}`, p);
  }
  const rows = [];
  for (const p of byKey.values()) {
    const schema = deref(p.schema) || {};
    if (p.in === "query" && schema.type === "object" && schema.properties && p.explode !== false) {
      for (const [name, prop] of Object.entries(schema.properties)) {
        const d = deref(prop) || {};
        rows.push({ name, in: "query", required: false, schema: prop,
                    description: d.description || "", group: p.name, groupDescription: p.description });
      }
    } else {
      rows.push({ name: p.name, in: p.in, required: Boolean(p.required), schema: p.schema, description: p.description || "" });
    }
  }
  return rows;
}

function parameterTable(rows) {
  const groupsShown = new Set();
  return el("table", { class: "params" },
    el("thead", {}, el("tr", {}, el("th", {}, "name"), el("th", {}, "in"), el("th", {}, "type"), el("th", {}, "description"))),
    el("tbody", {}, ...rows.map((r) => {
      const s = deref(r.schema) || {};
      const notes = constraints(s);
      const groupNote = r.group && !groupsShown.has(r.group) ? r.groupDescription : null;
      if (r.group) groupsShown.add(r.group);
      return el("tr", {},
        el("td", { class: "prop-name" }, el("code", {}, r.name), r.required ? el("span", { class: "required", title: "required" }, " *") : null),
        el("td", {}, r.in),
        el("td", { class: "prop-type" }, ...typeNodes(r.schema)),
        el("td", {}, groupNote ? prose(groupNote, "prose small") : null,
           r.description ? prose(r.description, "prose small") : null, notes ? el("div", { class: "meta" }, notes) : null));
    })));
}

function requestBody(op) {
  const body = deref(op.requestBody);
  if (!body) return null;
  const section = el("div", { class: "op-part" }, el("h4", {}, "Request body", body.required ? "" : " (optional)"));
  if (body.description) section.append(prose(body.description));
  for (const [type, media] of Object.entries(body.content || {})) {
    section.append(el("div", { class: "media-type" }, el("code", {}, type)));
    if (media.schema) section.append(bodySchema(media.schema));
    section.append(...examplesOf(media));
  }
  return section;
}

function statusClass(status) {
  return `status status-${String(status)[0]}xx`;
}

function responses(op) {
  const rows = [];
  for (const [status, raw] of Object.entries(op.responses || {})) {
    const r = deref(raw) || {};
    const cell = el("td", {}, prose(r.description || "", "prose small"));
    for (const [type, media] of Object.entries(r.content || {})) {
      cell.append(el("div", { class: "media-type" }, el("code", {}, type), media.schema ? " " : null,
                     ...(media.schema ? typeNodes(media.schema) : [])));
      cell.append(...examplesOf(media));
    }
    const headers = Object.entries(r.headers || {}).map(([name, h]) => {
      const hd = deref(h) || {};
      return el("li", {}, el("code", {}, name), hd.description ? `: ${hd.description}` : "");
    });
    if (headers.length) cell.append(el("ul", { class: "headers" }, ...headers));
    rows.push(el("tr", {}, el("td", {}, el("span", { class: statusClass(status) }, status)), cell));
  }
  if (!rows.length) return null;
  return el("div", { class: "op-part" }, el("h4", {}, "Responses"),
            el("table", { class: "responses" }, el("tbody", {}, ...rows)));
}

function operation(path, method, pathItem, op) {
  const role = roleOf(op);
  const summary = (op.summary || "").replace(ROLE_SUFFIX, "");
  const params = parametersOf(pathItem, op);
  return el("section", { class: "op", id: opAnchor(op, method, path), "data-path": path, "data-method": method },
    el("h3", {}, el("span", { class: `method method-${method}` }, method.toUpperCase()), " ",
       el("code", { class: "path" }, path),
       role ? el("span", { class: `role role-${role.split("/")[0]}`, title: "the role it needs" }, role) : null),
    summary ? el("p", { class: "summary" }, ...inline(summary)) : null,
    op.description ? prose(op.description) : null,
    params.length ? el("div", { class: "op-part" }, el("h4", {}, "Parameters"), parameterTable(params)) : null,
    requestBody(op),
    responses(op));
}

// [{tag, description, ops: [{path, method, pathItem, op}]}] in the document's tag order.
function operationsByTag() {
  const tags = new Map((doc.tags || []).map((t) => [t.name, { tag: t.name, description: t.description, ops: [] }]));
  for (const [path, pathItem] of Object.entries(doc.paths || {})) {
    for (const method of METHODS) {
      const op = pathItem[method];
      if (!op) continue;
      const tag = op.tags?.[0] || "other";
      if (!tags.has(tag)) tags.set(tag, { tag, ops: [] });
      tags.get(tag).ops.push({ path, method, pathItem, op });
    }
  }
  return [...tags.values()].filter((t) => t.ops.length);
}

// ---------------------------------------------------------------------------------------------
// The page

function overview() {
  const info = doc.info || {};
  const servers = (doc.servers || []).map((s) => el("li", {}, el("code", {}, s.url), s.description ? ` ${s.description}` : ""));
  const schemes = Object.entries(doc.components?.securitySchemes || {}).map(([name, s]) =>
    el("li", {}, el("code", {}, name), `: ${s.type}${s.scheme ? ` ${s.scheme}` : ""}${s.in ? ` in ${s.in} ${s.name}` : ""}`,
       s.description ? ` (${s.description})` : ""));
  return el("section", { class: "docs-overview", id: "overview" },
    el("h2", {}, `${info.title || "API"} ${info.version || ""}`),
    info.summary ? el("p", { class: "summary" }, info.summary) : null,
    prose(info.description),
    el("p", { class: "meta" }, `OpenAPI ${doc.openapi || "?"} · `, el("a", { href: "/api/v1/openapi.yaml" }, "the YAML document")),
    servers.length ? el("div", {}, el("h4", {}, "Servers"), el("ul", {}, ...servers)) : null,
    schemes.length ? el("div", {}, el("h4", {}, "Security schemes"), el("ul", {}, ...schemes)) : null);
}

function schemasSection() {
  const schemas = Object.entries(doc.components?.schemas || {});
  return el("section", { class: "docs-schemas", id: "schemas" }, el("h2", {}, "Schemas"),
    ...schemas.map(([name, s]) => el("section", { class: "schema", id: schemaAnchor(name), "data-schema": name },
      el("h3", {}, el("code", {}, name)),
      s.description ? prose(s.description) : null,
      schemaBody({ ...s, description: undefined }),
      s.example !== undefined ? exampleBlock("Example", s.example) : null)));
}

function tableOfContents(groups) {
  const link = (href, ...text) => el("a", { href }, ...text);
  return [
    el("h2", {}, "Contents"),
    el("ul", {},
      el("li", {}, link("#overview", "Overview")),
      ...groups.map((g) => el("li", { class: "toc-tag" }, link(`#tag-${g.tag}`, g.tag),
        el("ul", {}, ...g.ops.map(({ path, method, op }) => el("li", {},
          link(`#${opAnchor(op, method, path)}`, el("span", { class: `method method-${method}` }, method.toUpperCase()),
               el("span", { class: "toc-path" }, path))))))),
      el("li", {}, link("#schemas", "Schemas"))),
  ];
}

function render() {
  const groups = operationsByTag();
  const main = document.getElementById("docs");
  main.replaceChildren(overview(),
    ...groups.map((g) => el("section", { class: "tag", id: `tag-${g.tag}`, "data-tag": g.tag },
      el("h2", {}, g.tag), g.description ? prose(g.description) : null,
      ...g.ops.map(({ path, method, pathItem, op }) => operation(path, method, pathItem, op)))),
    schemasSection());
  document.getElementById("docs-toc").replaceChildren(...tableOfContents(groups));
  document.title = `${doc.info?.title || "API"} ${doc.info?.version || ""} · API docs`;
  // The address's #anchor did not exist before the render: go there now.
  if (location.hash) document.getElementById(decodeURIComponent(location.hash.slice(1)))?.scrollIntoView();
}

async function load() {
  const status = document.getElementById("docs-status");
  try {
    const res = await fetch("/api/v1/openapi.yaml");
    if (!res.ok) throw new Error(`GET /api/v1/openapi.yaml answered ${res.status}`);
    doc = globalThis.jsyaml.load(await res.text());
    render();
    document.body.dataset.docs = "ready";
  } catch (e) {
    status.textContent = `Could not show the API docs: ${e.message}`;
    status.className = "error";
    document.body.dataset.docs = "failed";
  }
}

// A printout shows every example, folded or not.
window.addEventListener("beforeprint", () => {
  for (const d of document.querySelectorAll("details")) d.open = true;
});
load();
