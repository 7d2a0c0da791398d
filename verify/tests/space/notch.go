// Both waypoints are inside an L-shaped fence; the diagonal between them
// cuts its notch.
package Notch

var D1 Quadcopter

func SEQ_Mission() {
	D1.Arm()
	D1.Takeoff(5)
	D1.FlyByX(15)
	D1.FlyTo(2, 15, 5)
	D1.Land()
}
