// The page's bytes in and out: files opened (fetched or dropped; a .gz decompressed by the browser's gzip: the
// module has no zlib), files saved, bytes handed to the tests.
import { InputError } from './formats.js';

/** The file's bytes; a .gz decompressed by the browser's own gzip (the module has no zlib). */
export async function bytesOf(source, name) {
  const gz = /\.gz$/i.test(name);
  let stream = source instanceof Blob ? source.stream() : source.body;
  if (gz) stream = stream.pipeThrough(new DecompressionStream('gzip'));
  try {
    return new Uint8Array(await new Response(stream).arrayBuffer());
  } catch (e) {
    throw new InputError(name, gz ? `corrupt gzip data (${e.message})` : `cannot read: ${e.message}`);
  }
}

export async function fetchBytes(url) {
  const r = await fetch(url);
  if (!r.ok) throw new InputError(url, `cannot open: HTTP ${r.status}`);
  return bytesOf(r, url);
}

export function save(text, name) {
  const a = document.createElement('a');
  a.href = URL.createObjectURL(new Blob([text], { type: 'application/octet-stream' }));
  a.download = name;
  a.click();
  URL.revokeObjectURL(a.href);
}

/** Bytes as base64 text (what window.mlsdeformPage hands to the tests). */
export function base64(bytes) {
  let s = '';
  for (let i = 0; i < bytes.length; i += 0x8000) s += String.fromCharCode(...bytes.subarray(i, i + 0x8000));
  return btoa(s);
}
