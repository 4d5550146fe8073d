// The job API as the page uses it (see /openapi.yaml). Every failure is
// thrown as an ApiError carrying the problem+json document when there is one.
// When the server runs with API keys, the key the person entered is sent as
// a bearer token on every /v1 request; it is kept for this tab only
// (sessionStorage), never in a cookie or a URL.

const KEY_ITEM = 'isoremesh-api-key';

/** The API key in use, or '' when none was entered. */
export const apiKey = () => sessionStorage.getItem(KEY_ITEM) ?? '';

/** Uses `key` for the following requests ('' forgets it). */
export function setApiKey(key) {
  if (key) sessionStorage.setItem(KEY_ITEM, key);
  else sessionStorage.removeItem(KEY_ITEM);
}

function withKey(init = {}) {
  const key = apiKey();
  if (!key) return init;
  return { ...init, headers: { ...(init.headers ?? {}), Authorization: `Bearer ${key}` } };
}

export class ApiError extends Error {
  constructor(problem) {
    super(problem.detail || problem.title || 'request failed');
    this.problem = problem;
  }
}

async function check(response) {
  if (response.ok) return response;
  let problem;
  try {
    problem = await response.json();
  } catch {
    problem = { title: response.statusText, status: response.status };
  }
  problem.status ??= response.status;
  throw new ApiError(problem);
}

async function json(url, init) {
  return (await check(await fetch(url, withKey(init)))).json();
}

/** Submits a job: `mesh` is a File, `extra` more files sent as named parts. */
export function submit(mesh, params, extra = []) {
  const body = new FormData();
  body.append('mesh', mesh, mesh.name);
  body.append('params', new Blob([JSON.stringify(params)], { type: 'application/json' }));
  for (const f of extra) body.append(f.name, f, f.name);
  return json('/v1/jobs', { method: 'POST', body });
}

export const getJob = (id) => json(`/v1/jobs/${encodeURIComponent(id)}`);
export const listJobs = (limit = 20) => json(`/v1/jobs?limit=${limit}`);
export const cancelJob = (id) =>
  json(`/v1/jobs/${encodeURIComponent(id)}/cancel`, { method: 'POST' });

/** The result as bytes in `format` (re-encoded by the server if needed). */
export async function resultBytes(id, format) {
  const r = await check(await fetch(resultUrl(id, format), withKey()));
  return r.arrayBuffer();
}

/** The file behind a result URL (downloads that need the key): its bytes
 * and the name the server gives it. */
export async function resultFile(url) {
  const r = await check(await fetch(url, withKey()));
  const name = /filename="([^"]+)"/.exec(r.headers.get('content-disposition') ?? '')?.[1] ?? '';
  return { blob: await r.blob(), name };
}

export const resultUrl = (id, format) =>
  `/v1/jobs/${encodeURIComponent(id)}/result?format=${encodeURIComponent(format)}`;

export const defaults = async () => (await check(await fetch('/assets/defaults.json'))).json();
