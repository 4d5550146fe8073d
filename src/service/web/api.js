// The job API as the page uses it (see /openapi.yaml). Every failure is
// thrown as an ApiError carrying the problem+json document when there is one.

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
  return (await check(await fetch(url, init))).json();
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
  const r = await check(await fetch(resultUrl(id, format)));
  return r.arrayBuffer();
}

export const resultUrl = (id, format) =>
  `/v1/jobs/${encodeURIComponent(id)}/result?format=${encodeURIComponent(format)}`;

export const defaults = () => json('/assets/defaults.json');
