// The page's splat scenes on screen (docs/web.md, "Splat scenes"): Spark (@sparkjsdev/spark, pinned) draws the
// splats that the module deformed and packed in Spark's own layout (web/src/spark_pack.hpp); each pose copies
// those arrays into Spark's and marks its textures for upload, so that Spark's mesh is never rebuilt during a
// drag. Picking finds the splat centre nearest the ray (a handle sits on a splat, by its index: the program's
// `vertex`).
import * as THREE from 'three';

export class SplatView {
  constructor(renderer, scene) {
    this.renderer = renderer;
    this.scene = scene;
    this.spark = null;
    this.mesh = null;
    this.packed = null;
  }

  /** Loads Spark (0.9 MB compressed: only when a splat scene is opened). */
  async load() {
    this.Spark ??= await import('@sparkjsdev/spark');
  }

  /** Shows the module's scene (mlsdeform.js SplatScene) in place of what was shown; returns Spark's mesh. */
  show(splats) {
    const { SparkRenderer, SplatMesh, PackedSplats } = this.Spark;
    if (!this.spark && this.scene) {  // none for the benchmark, which never draws
      this.spark = new SparkRenderer({ renderer: this.renderer });
      this.scene.add(this.spark);
    }
    this.dispose();
    splats.views();
    const extra = {};
    for (const band of [1, 2, 3]) if (splats.sh(band)) extra[`sh${band}`] = splats.sh(band).slice();
    // The ranges the module packed with (its SplatMesh sets the packed splats' encoding: given to both).
    const splatEncoding = { ...splats.encoding, lodOpacity: false };
    this.packed = new PackedSplats({ packedArray: splats.packed.slice(), numSplats: splats.count, splatEncoding, extra });
    this.splats = splats;
    this.mesh = new SplatMesh({ packedSplats: this.packed, splatEncoding, raycastable: false });
    return this.mesh;
  }

  /** After a pose: the module's arrays into Spark's, their textures marked for upload. */
  update() {
    const { packed, splats } = this;
    splats.views();
    packed.packedArray.set(splats.packed);
    for (const band of [1, 2, 3]) {
      const from = splats.sh(band);
      if (!from) continue;
      packed.extra[`sh${band}`].set(from);
      const texture = packed.extra[`sh${band}Texture`]?.value;
      if (texture) texture.needsUpdate = true;
    }
    packed.needsUpdate = true;
    this.mesh.updateVersion();
  }

  /** The textures uploaded now, as a frame would before drawing (for the benchmark: upload without render). */
  uploadNow() {
    const { packed } = this;
    this.renderer.initTexture(packed.getTexture());
    for (const band of [1, 2, 3]) {
      const texture = packed.extra[`sh${band}Texture`]?.value;
      if (texture) this.renderer.initTexture(texture);
    }
  }

  /** The index of the splat whose centre is nearest the camera among those within `tolerance` of the ray. */
  pick(ray, tolerance) {
    const c = this.splats.centres, o = ray.origin, d = ray.direction;
    let best = -1, bestT = Infinity;
    const tol2 = tolerance * tolerance;
    for (let i = 0; i < c.length; i += 3) {
      const x = c[i] - o.x, y = c[i + 1] - o.y, z = c[i + 2] - o.z;
      const t = x * d.x + y * d.y + z * d.z;
      if (t <= 0 || t >= bestT) continue;
      if (x * x + y * y + z * z - t * t <= tol2) (best = i / 3), (bestT = t);
    }
    return best;
  }

  dispose() {
    if (this.mesh) {
      this.mesh.removeFromParent();
      this.mesh.dispose();
    }
    this.mesh = this.packed = null;
  }
}

/** The bounding sphere of xyz. */
export function boundsOf(xyz) {
  const box = new THREE.Box3();
  const p = new THREE.Vector3();
  for (let i = 0; i < xyz.length; i += 3) box.expandByPoint(p.fromArray(xyz, i));
  return box.getBoundingSphere(new THREE.Sphere());
}
