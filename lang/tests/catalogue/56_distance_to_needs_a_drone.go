// DistanceTo takes a drone; property argument counts are checked.
package DistanceArg

var D1 Quadcopter
var D2 Quadcopter

func INIT() {
	WaitUntil(D1.DistanceTo(3) > 2, SEQ_Go)
	WaitUntil(D1.DistanceTo() > 2, SEQ_Go)
	WaitUntil(D1.DistanceTo(D3) > 2, SEQ_Go)
}

func SEQ_Go() {
	D2.Land()
}
