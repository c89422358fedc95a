// The server's rig schema for the node tests (GET /v1/schema as protocol::schemaJson() writes it):
// tests/unit/protocol_parity_cases_test.cpp writes it and CTest passes its path in
// DFB_SCHEMA_JSON (web_modules and web_parity run after that test). By hand:
//   DFB_SCHEMA_JSON=build/tests/data/rig_schema.json node --test tests/web/

import { readFileSync } from "node:fs";

import { setSchema } from "../../client/web/rig.js";

const path = process.env.DFB_SCHEMA_JSON;
if (!path) throw new Error("DFB_SCHEMA_JSON is not set: run through CTest (ctest -R web_), or see tests/web/schema.mjs");
export const serverSchema = JSON.parse(readFileSync(path, "utf8"));
/** Gives the rig model the server's rows (again, after a test gave it others). */
export const useServerSchema = () => setSchema(serverSchema);
useServerSchema();
