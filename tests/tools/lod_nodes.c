/* lod_nodes.c — reads a LOD group file (lods.glb, lods.fbx, docs/outputs.md)
 * back with assimp, as an engine's importer would, and prints one line per
 * node whose name ends in _LOD<i>, in the file's order:
 *
 *   NAME meshes=M triangles=T textures=K missing=X
 *
 * T counts the node's (and its children's) triangles, K the base-colour
 * textures its materials sample that resolve (an embedded image of the file,
 * or a file beside it), X those that do not. Exit 1 when the file does not
 * import. For tests/integration/bake_cli.sh.
 *
 * usage: lod_nodes FILE
 */
#include <assimp/cimport.h>
#include <assimp/material.h>
#include <assimp/scene.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static const char *dir_of_file;

/* Whether the texture path p of scene s resolves. */
static int resolves(const struct aiScene *s, const char *p)
{
    if (p[0] == '*') {
        long k = strtol(p + 1, NULL, 10);
        return k >= 0 && (unsigned)k < s->mNumTextures && s->mTextures[k]->mWidth > 0;
    }
    char path[4096];
    snprintf(path, sizeof path, "%s/%s", dir_of_file, p);
    return access(path, R_OK) == 0;
}

static void count(const struct aiScene *s, const struct aiNode *n, unsigned *meshes,
                  unsigned long *tris, unsigned *tex, unsigned *missing)
{
    for (unsigned i = 0; i < n->mNumMeshes; i++) {
        const struct aiMesh *m = s->mMeshes[n->mMeshes[i]];
        (*meshes)++;
        *tris += m->mNumFaces;
        const struct aiMaterial *mat = s->mMaterials[m->mMaterialIndex];
        struct aiString p;
        if (aiGetMaterialTexture(mat, aiTextureType_DIFFUSE, 0, &p, NULL, NULL, NULL, NULL, NULL,
                                 NULL) == aiReturn_SUCCESS ||
            aiGetMaterialTexture(mat, aiTextureType_BASE_COLOR, 0, &p, NULL, NULL, NULL, NULL, NULL,
                                 NULL) == aiReturn_SUCCESS) {
            if (resolves(s, p.data)) (*tex)++;
            else (*missing)++;
        }
    }
    for (unsigned i = 0; i < n->mNumChildren; i++)
        count(s, n->mChildren[i], meshes, tris, tex, missing);
}

static void walk(const struct aiScene *s, const struct aiNode *n)
{
    const char *l = strstr(n->mName.data, "_LOD");
    if (l && l[4] >= '0' && l[4] <= '9' && strspn(l + 4, "0123456789") == strlen(l + 4)) {
        unsigned meshes = 0, tex = 0, missing = 0;
        unsigned long tris = 0;
        count(s, n, &meshes, &tris, &tex, &missing);
        printf("%s meshes=%u triangles=%lu textures=%u missing=%u\n", n->mName.data, meshes, tris,
               tex, missing);
        return;
    }
    for (unsigned i = 0; i < n->mNumChildren; i++) walk(s, n->mChildren[i]);
}

int main(int argc, char **argv)
{
    if (argc != 2) {
        fprintf(stderr, "usage: lod_nodes FILE\n");
        return 2;
    }
    static char dir[4096];
    snprintf(dir, sizeof dir, "%s", argv[1]);
    char *slash = strrchr(dir, '/');
    if (slash) *slash = 0;
    else snprintf(dir, sizeof dir, ".");
    dir_of_file = dir;
    const struct aiScene *s = aiImportFile(argv[1], 0);
    if (!s || !s->mRootNode) {
        fprintf(stderr, "lod_nodes: %s: %s\n", argv[1], aiGetErrorString());
        return 1;
    }
    walk(s, s->mRootNode);
    aiReleaseImport(s);
    return 0;
}
